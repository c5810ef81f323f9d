"""Confidence of a mirror plane: the probability that it is within 10 deg and 10 mm of the truth.

A logistic model of two supports (:mod:`symjax.completion.support`): the found plane's, and the
best of its rivals' (the same plane turned by 15-40 deg and shifted by up to 2 cm). A plane that
lands little of the view on itself while a rival lands much more is a plane the vote chose only
because it mirrored the view into occluded space.

Calibrated on the embedded benchmark (104 views whose objects have a known plane, 32 of them
off by more than 10 deg or 10 mm; ``python scripts/bench_completion.py``): ROC AUC 0.80 on those
views; 0.71 when each object's views are scored by a model fitted without that object; the
vote of Eq. 3 alone, the threshold the paper proposed, reaches 0.65.
"""

from __future__ import annotations

import math

__all__ = ["CONFIDENCE_MODEL", "plane_confidence", "roc_auc"]

#: ``P(bad) = sigmoid(bias + w_support * ln(support + floor) + w_rival * ln(rival + floor))``,
#: fitted by L2-regularised logistic regression on the benchmark (see the module docstring).
CONFIDENCE_MODEL = {"bias": -2.10, "w_support": -1.46, "w_rival": 0.88, "floor": 0.02}


def plane_confidence(support: float, rival_support: float) -> float:
    """Probability in (0, 1) that the plane is right (within 10 deg and 10 mm of the truth).

    Args:
        support: The plane's support in [0, 1].
        rival_support: The best rival plane's support in [0, 1].

    Returns:
        The confidence; NaN when a support is NaN.
    """
    m = CONFIDENCE_MODEL
    if not (math.isfinite(support) and math.isfinite(rival_support)):
        return math.nan
    z = (
        m["bias"]
        + m["w_support"] * math.log(max(support, 0.0) + m["floor"])
        + m["w_rival"] * math.log(max(rival_support, 0.0) + m["floor"])
    )
    return 1.0 - 1.0 / (1.0 + math.exp(-z))


def roc_auc(scores, bad) -> float:
    """ROC AUC of ``scores`` (high = good) at telling the ``bad`` cases (bool) from the rest:
    the chance that a random good case scores above a random bad one (ties count half).

    Returns:
        The AUC in [0, 1]; NaN without both kinds of case or with a NaN score.
    """
    import numpy as np

    s = np.asarray(scores, np.float64)
    b = np.asarray(bad, bool)
    if s.shape != b.shape or not np.all(np.isfinite(s)) or b.all() or not b.any():
        return math.nan
    good, worse = s[~b][:, None], s[b][None, :]
    return float(np.mean(good > worse) + 0.5 * np.mean(good == worse))
