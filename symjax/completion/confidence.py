"""Confidence of a mirror plane: the probability that it is within 10 deg and 10 mm of the truth.

A logistic model of two supports (:mod:`symjax.completion.support`) and the axis residual of the
visible surface (:mod:`symjax.completion.revolution`): the found plane's support, the best of
its rivals' (the same plane turned by 15-40 deg and shifted by up to 2 cm), and how nearly the
visible surface is one of revolution. A plane that lands little of the view on itself while a
rival lands much more is a plane the vote chose only because it mirrored the view into occluded
space; a surface that is nearly, but not quite, one of revolution (a mug with its handle hidden,
a pitcher, a bottle's shoulders) supports every plane through its axis alike, so the vote picks
among them by chance. The residual enters as a quadratic in its logarithm: the confidence dips
for those surfaces and rises for true surfaces of revolution (any plane through the axis is
right) and for flat-sided ones.

Calibrated on the embedded benchmark (104 views whose objects have a known plane, 32 of them
off by more than 10 deg or 10 mm; ``python scripts/bench_completion.py``): ROC AUC 0.87 on those
views (0.80 with the two supports alone); 0.74 when each object's views are scored by a model
fitted without that object (0.71); the vote of Eq. 3 alone, the threshold the paper proposed,
reaches 0.65.
"""

from __future__ import annotations

import math

__all__ = ["CONFIDENCE_MODEL", "confidence_features", "plane_confidence", "roc_auc"]

#: ``P(bad) = sigmoid(bias + w_support * ln(support + floor) + w_rival * ln(rival + floor)
#: + w_axis * a + w_axis2 * a**2)``, ``a = ln(clip(axis residual, *axis_clip))``, fitted by
#: logistic regression (L2 weight ``l2`` on the slopes) on the benchmark (see the module
#: docstring).
CONFIDENCE_MODEL = {
    "bias": -2.052,
    "w_support": -2.033,
    "w_rival": 2.416,
    "w_axis": -3.23,
    "w_axis2": -1.845,
    "floor": 0.02,
    "axis_clip": (0.05, 2.0),
    "l2": 0.1,
}


def confidence_features(support: float, rival_support: float, axis_residual: float) -> list:
    """The model's inputs ``[ln(support + floor), ln(rival + floor), a, a**2]``; a residual that
    is not finite (no axis could be fitted) counts as the clip's upper end."""
    m = CONFIDENCE_MODEL
    lo, hi = m["axis_clip"]
    r = axis_residual if math.isfinite(axis_residual) else hi
    a = math.log(min(max(r, lo), hi))
    return [
        math.log(max(support, 0.0) + m["floor"]),
        math.log(max(rival_support, 0.0) + m["floor"]),
        a,
        a * a,
    ]


def plane_confidence(support: float, rival_support: float, axis_residual: float) -> float:
    """Probability in (0, 1) that the plane is right (within 10 deg and 10 mm of the truth).

    Args:
        support: The plane's support in [0, 1].
        rival_support: The best rival plane's support in [0, 1].
        axis_residual: The visible surface's axis residual
            (:attr:`~symjax.completion.RevolutionFit.residual`; NaN or inf: no axis).

    Returns:
        The confidence; NaN when a support is NaN.
    """
    m = CONFIDENCE_MODEL
    if not (math.isfinite(support) and math.isfinite(rival_support)):
        return math.nan
    x = confidence_features(support, rival_support, axis_residual)
    w = (m["w_support"], m["w_rival"], m["w_axis"], m["w_axis2"])
    z = m["bias"] + sum(wi * xi for wi, xi in zip(w, x, strict=True))
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
