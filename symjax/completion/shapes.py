"""The K most plausible shapes of a view, weighted, for planning under shape uncertainty.

The paper plans on one completion and names "planners that take uncertain shape information
explicitly into account" as future work. A view gets up to three shapes: the completion
:func:`~symjax.completion.choose_completion` chooses, the mirror across the best plane of the
search that is distinct from the found one, and the footprint hull (the least the object
occupies). The weights follow the found completion's confidence: it keeps ``(1 + c) / 2``, the
others share the rest, so a sure plane dominates and an unsure one lets the alternatives count.
"""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np

from symjax.completion.choice import Completion, choose_completion
from symjax.completion.config import CompletionConfig
from symjax.completion.fallback import footprint_hull, grid_planes
from symjax.errors import SymjaxError, config_or_default

__all__ = ["ShapeSet", "distinct_plane", "plausible_shapes", "shape_weight"]


@dataclasses.dataclass(frozen=True)
class ShapeSet:
    """The plausible shapes of one object, most plausible first.

    Attributes:
        meshes: K watertight ``trimesh.Trimesh`` (world frame, metres).
        weights: (K,) probabilities, summing to 1.
        kinds: Per shape ``"mirror"``, ``"revolution"``, ``"fallback"`` or ``"alternative
            mirror"``.
        reasons: Per shape, why it is there and its weight, in words.
    """

    meshes: tuple
    weights: np.ndarray
    kinds: tuple[str, ...]
    reasons: tuple[str, ...]

    def __post_init__(self) -> None:
        from symjax.errors import InvalidInputError

        w = np.asarray(self.weights, np.float64)
        k = len(self.meshes)
        if k == 0 or w.shape != (k,) or len(self.kinds) != k or len(self.reasons) != k:
            raise InvalidInputError(
                f"ShapeSet: {k} meshes, weights {w.shape}, {len(self.kinds)}"
                " kinds, expected one of each per shape (at least one)"
            )
        if not (np.all(np.isfinite(w)) and np.all(w >= 0) and abs(w.sum() - 1.0) < 1e-6):
            raise InvalidInputError(f"ShapeSet weights {w.tolist()}: expected >= 0, summing to 1")
        object.__setattr__(self, "weights", w)

    def __len__(self) -> int:
        return len(self.meshes)

    @classmethod
    def single(cls, mesh: Any, kind: str = "given") -> ShapeSet:
        """One shape of weight 1."""
        return cls((mesh,), np.ones(1), (kind,), ("the only shape",))


def shape_weight(completion: Completion, config: CompletionConfig) -> float:
    """The chosen completion's weight among the shapes, in [0.5, 1].

    The mirror's is ``(1 + confidence) / 2``; a revolution's ``(1 + r) / 2`` with ``r`` one
    minus the axis residual's share of its threshold (a perfect surface of revolution: 1).
    """
    if completion.kind == "revolution":
        r = 1.0 - completion.revolution.residual / config.revolution_residual
        return 0.5 * (1.0 + float(np.clip(r, 0.0, 1.0)))
    return 0.5 * (1.0 + float(np.clip(completion.confidence, 0.0, 1.0)))


def distinct_plane(
    result: Any, table_normal: np.ndarray, min_deg: float
) -> tuple[np.ndarray, float, float] | None:
    """The best plane of the search's first grid whose orientation differs from the found
    plane's by at least ``min_deg``: ``(normal (3,), offset, vote)``, or None if there is none.

    Args:
        result: A single-view :class:`~symjax.symmetry.SymmetryResult`.
        table_normal: (3,) the table's unit normal.
        min_deg: Least difference of orientation, degrees (planes: modulo 180 deg).
    """
    normals, offsets, votes = grid_planes(result, table_normal)
    found = np.asarray(result.normal, np.float64)
    apart = np.degrees(np.arccos(np.clip(np.abs(normals @ found), 0.0, 1.0)))
    best = np.where(np.isfinite(votes), votes, np.inf).min(axis=2)
    best = np.where(apart >= min_deg, best, np.inf)
    if not np.isfinite(best).any():
        return None
    i, j = np.unravel_index(int(np.argmin(best)), best.shape)
    k = int(np.argmin(votes[i, j]))
    return normals[i, j], float(offsets[i, j, k]), float(best[i, j])


def _members(result: Any, obs: Any, cfg: Any) -> tuple[list, list]:
    """``(shapes, oriented)``: per shape ``[kind, reason, weight, mesh or None]`` and the
    oriented clouds still to mesh, ``(shape index, OrientedPoints)``."""
    from symjax.surface.normals import oriented_completion
    from symjax.symmetry import mirror_across

    cc = config_or_default(cfg.completion, CompletionConfig)
    main = choose_completion(result, obs, cc, cfg.normals, cfg.symmetry)
    w = shape_weight(main, cc) if cc.shapes > 1 else 1.0
    shapes = [[main.kind, main.reason, w, main.mesh]]
    oriented = [] if main.mesh is not None else [(0, main.oriented)]
    rest: list = []
    if cc.shapes >= 2:
        alt = distinct_plane(result, obs.table.normal, cc.distinct_deg)
        if alt is not None:
            try:
                r = mirror_across(result, obs, alt[0], alt[1], cfg.symmetry)
                why = f"best plane >= {cc.distinct_deg:g} deg from the found one"
                why += f" (vote {alt[2]:.3g})"
                rest.append(["alternative mirror", why,
                             oriented_completion(r, obs.camera, cfg.normals)])  # fmt: skip
            except SymjaxError:
                pass
    if len(rest) < cc.shapes - 1 and main.mesh is None:  # the hull unless it is the main
        try:
            rest.append(["fallback", "footprint hull of the visible points",
                         footprint_hull(main.visible, obs.table)])  # fmt: skip
        except SymjaxError:
            pass
    rest = rest[: cc.shapes - 1]
    for kind, why, x in rest:
        share = (1.0 - w) / len(rest)
        mesh = x if kind == "fallback" else None
        shapes.append([kind, f"{why}; weight {share:.2f}", share, mesh])
        if kind != "fallback":
            oriented.append((len(shapes) - 1, x))
    if not rest:
        shapes[0][2] = 1.0
    shapes[0][1] += f"; weight {shapes[0][2]:.2f}"
    return shapes, oriented


def plausible_shapes(observations: list, cfg: Any, search: Any = None) -> list:
    """The plausible shapes of each observation: one batched symmetry search, every shape to
    mesh of every view in one batched Poisson solve (cut at each view's table and hull).

    Args:
        observations: :class:`symjax.Observation` list.
        cfg: A config with ``symmetry``, ``completion`` (``shapes``, ``distinct_deg``),
            ``normals``, ``poisson`` and ``execution``
            (:class:`~symjax.configs.stages.ShapeToGraspStages`).
        search: The batched :class:`~symjax.symmetry.SymmetryResult` of ``observations``, or
            None: searched here.

    Returns:
        Per observation a :class:`ShapeSet` or the :class:`SymjaxError` that kept its chosen
        completion from being built (an alternative that fails is left out).
    """
    from symjax.surface import poisson_reconstruct_batch
    from symjax.symmetry import search_or_errors

    res, out = search_or_errors(observations, cfg.symmetry, cfg.execution, search)
    members: dict[int, list] = {}
    jobs: list = []  # (view, shape index, OrientedPoints)
    for i, obs in enumerate(observations):
        if out[i] is not None:
            continue
        try:
            members[i], oriented = _members(res[i], obs, cfg)
        except SymjaxError as e:
            out[i] = e
            continue
        jobs += [(i, k, op) for k, op in oriented]
    if jobs:
        tables = [observations[i].table for i, _, _ in jobs]
        meshes = poisson_reconstruct_batch([op for _, _, op in jobs], cfg.poisson, cfg.execution,
                                           errors="keep", tables=tables)  # fmt: skip
        for (i, k, _), m in zip(jobs, meshes, strict=True):
            members[i][k][3] = m
    for i, shapes in members.items():
        if isinstance(shapes[0][3], SymjaxError):
            out[i] = shapes[0][3]
            continue
        good = [s for s in shapes if not isinstance(s[3], SymjaxError)]
        w = np.array([s[2] for s in good])
        w = w / w.sum()
        out[i] = ShapeSet(tuple(s[3] for s in good), w, tuple(s[0] for s in good),
                          tuple(s[1] for s in good))  # fmt: skip
    return out
