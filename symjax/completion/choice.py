"""The completed shape of one view: the mirror, the revolution or the fallback, and why."""

from __future__ import annotations

import dataclasses
from typing import Any, Literal

import numpy as np

from symjax.completion.confidence import plane_confidence
from symjax.completion.config import CompletionConfig
from symjax.completion.fallback import footprint_hull, supported_plane
from symjax.completion.revolution import RevolutionFit, fit_revolution, revolve
from symjax.completion.support import SupportIndex
from symjax.errors import ShapeError, config_or_default
from symjax.surface.config import NormalsConfig
from symjax.surface.normals import OrientedPoints, oriented_completion, oriented_observation

__all__ = ["Completion", "choose_completion"]

Kind = Literal["mirror", "revolution", "fallback"]


@dataclasses.dataclass(frozen=True)
class Completion:
    """How one view is completed, and how sure the plane is.

    Attributes:
        kind: ``"mirror"`` (the paper), ``"revolution"`` (turned about the fitted axis) or
            ``"fallback"`` (:mod:`symjax.completion.fallback`: the mirror across the near-best
            plane the view supports best, or the hull of the visible points and their table
            footprint).
        reason: Why this kind, in words with the numbers that decided it.
        confidence: Probability that the mirror plane is right (:func:`plane_confidence`).
        support: The plane's support in [0, 1] (:mod:`symjax.completion.support`).
        rival_support: The best rival plane's support.
        flagged: ``confidence < config.flag_below``: the mirror plane is likely wrong.
        revolution: The axis fit of the visible surface.
        oriented: Oriented points to mesh; None for the hull.
        mesh: The hull's watertight ``trimesh.Trimesh``; None otherwise.
        visible: (N, 3) the observed points the choice used (outliers removed), metres.
    """

    kind: Kind
    reason: str
    confidence: float
    support: float
    rival_support: float
    flagged: bool
    revolution: RevolutionFit
    oriented: OrientedPoints | None = None
    mesh: Any = None
    visible: Any = None


def choose_completion(
    result: Any,
    observation: Any,
    config: CompletionConfig | None = None,
    normals: NormalsConfig | None = None,
    symmetry: Any = None,
) -> Completion:
    """Chooses and builds the completion of one view from its symmetry search.

    With ``config.mode="auto"``: a visible surface of revolution about the table normal is
    revolved; otherwise the view is mirrored, unless the plane's confidence is below
    ``config.min_confidence``, where the fallback (``config.fallback``) replaces it.

    Args:
        result: A single-view :class:`~symjax.symmetry.SymmetryResult`.
        observation: The :class:`~symjax.Observation` it was searched on (camera and table).
        config: :class:`CompletionConfig` (mode, thresholds).
        normals: Normal estimation of the observed and completed clouds.
        symmetry: The search's :class:`~symjax.symmetry.SymmetryConfig` (None: the default),
            for the fallback's mirror across another plane.

    Returns:
        A :class:`Completion`.

    Raises:
        ShapeError: ``result`` is a batch (index it first).
        SymjaxError: The view's points are degenerate for normals or the fallback's hull.
    """
    cfg = config_or_default(config, CompletionConfig)
    if np.ndim(result.points) != 2:
        raise ShapeError("choose_completion() needs one view; index the batch first: result[i]")
    cam, table = observation.camera, observation.table
    observed = oriented_observation(
        np.asarray(result.points)[np.asarray(result.valid, bool)], cam, normals
    )
    index = SupportIndex(observed.points, cfg.support_samples)
    normal, offset = np.asarray(result.normal, np.float64), float(result.offset)
    support = index.support(normal, offset, cfg.support_eps)
    rival = index.rival_support(normal, offset, np.asarray(table.normal), cfg)
    fit = fit_revolution(observed, np.asarray(table.normal, np.float64), cfg)
    conf = plane_confidence(support, rival, fit.residual)
    facts = dict(confidence=conf, support=support, rival_support=rival, revolution=fit,
                 visible=observed.points)  # fmt: skip
    facts["flagged"] = bool(conf < cfg.flag_below)
    axis = np.isfinite(fit.residual)
    why_rot = f"axis residual {fit.residual:.3f} <= {cfg.revolution_residual}"
    why_conf = (f"plane support {support:.2f} (best rival {rival:.2f}, axis residual"
                f" {fit.residual:.2f}), confidence {conf:.2f}")  # fmt: skip
    if cfg.mode == "revolution" and axis or cfg.mode == "auto" and fit.rotational:
        reason = f"visible surface is rotational ({why_rot})" if fit.rotational else (
            f"revolution asked for (axis residual {fit.residual:.3f})"
        )  # fmt: skip
        oriented = revolve(observed, fit, cfg.revolution_copies)
        return Completion("revolution", reason, oriented=oriented, **facts)
    if cfg.mode == "fallback" or cfg.mode == "auto" and conf < cfg.min_confidence:
        why = f"{why_conf} < {cfg.min_confidence}" if cfg.mode == "auto" else "fallback asked for"
        if cfg.fallback == "hull":
            why += ": the hull of the visible points and their footprint"
            return Completion("fallback", why, mesh=footprint_hull(observed.points, table), **facts)
        plane = supported_plane(result, np.asarray(table.normal), index, support, cfg)
        if plane is not None:
            from symjax.symmetry import mirror_across

            moved = mirror_across(result, observation, plane[0], plane[1], symmetry)
            why += (f": mirrored across the plane the view supports best among those whose"
                    f" vote is within {cfg.support_vote_ratio:g}x of the best (support"
                    f" {plane[2]:.2f})")  # fmt: skip
            oriented = oriented_completion(moved, cam, normals)
            return Completion("fallback", why, oriented=oriented, **facts)
        why_conf = (f"{why}; no near-best plane is supported {cfg.support_gain:g} more than the"
                    " found one: the mirror is kept")  # fmt: skip
    reason = why_conf if cfg.mode != "revolution" else f"no axis to revolve about; {why_conf}"
    return Completion("mirror", reason, oriented=oriented_completion(result, cam, normals), **facts)
