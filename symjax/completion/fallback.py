"""What replaces the mirror of a view whose plane is likely wrong (beyond the paper).

Two fallbacks. ``"support"``: among the planes of the search that Eq. 3 finds about as good as
the winner (a vote within ``support_vote_ratio`` of the best), the one the view supports best
(the paper's case i, :mod:`symjax.completion.support`), when it clearly beats the found plane's
support. A wrong plane wins the vote by mirroring the view into occluded space, where nothing
contradicts it; a near-best plane that also maps the view onto itself is the better guess.
``"hull"``: the convex hull of the visible points and their footprint on the table, the least
the object occupies (conservative, but it has no back: it deviates more than the mirror).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from symjax.completion.config import CompletionConfig
from symjax.completion.support import SupportIndex

__all__ = ["footprint_hull", "grid_planes", "supported_plane"]


def footprint_hull(points: np.ndarray, table: Any):
    """Convex hull of the points and their projections onto the table (a watertight mesh).

    The least an object standing on the table occupies if it is convex: nothing of it is
    assumed behind what was seen except the column down to the table. Points below the table
    (depth noise) are lifted onto it: nothing of the object is under the table.

    Raises:
        DegenerateGeometryError: Fewer than 4 points or no volume.
    """
    import trimesh

    from symjax.errors import DegenerateGeometryError

    p = np.asarray(points, np.float64)
    if p.ndim != 2 or p.shape[1] != 3 or len(p) < 3:
        raise DegenerateGeometryError(f"a footprint hull needs >= 3 points (N, 3), got {p.shape}")
    n = np.asarray(table.normal, np.float64)
    height = np.asarray(table.height(p), np.float64)
    p = p - np.minimum(height, 0.0)[:, None] * n
    foot = p - np.maximum(height, 0.0)[:, None] * n
    try:
        hull = trimesh.Trimesh(np.concatenate([p, foot])).convex_hull
    except Exception as e:  # qhull's own errors on flat or tiny input
        raise DegenerateGeometryError(f"no footprint hull of {len(p)} points: {e}") from None
    if not hull.is_volume or hull.volume <= 0:
        raise DegenerateGeometryError(f"the footprint hull of {len(p)} points has no volume")
    return hull


def grid_planes(result: Any, table_normal: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The planes of the search's first grid.

    Args:
        result: A single-view :class:`~symjax.symmetry.SymmetryResult`.
        table_normal: (3,) the table's unit normal.

    Returns:
        ``(normals (S, A, 3), offsets (S, A, K), votes (S, A, K))`` over starts, angles and
        shifts; a vote is Eq. 3's penalty (lower is better; inf or NaN: not scored).
    """
    votes = np.asarray(result.votes, np.float64)  # (starts, angles, shifts)
    angles = np.asarray(result.angles, np.float64)  # (starts, angles)
    shifts = np.asarray(result.shifts, np.float64)
    # The grid's frame (symjax.symmetry.hypotheses): s = m0 x n, so m0 = n x s, side = n x m0.
    n = np.asarray(table_normal, np.float64)
    m0 = np.cross(n, np.asarray(result.initial_axis, np.float64))
    side = np.cross(n, m0)
    normals = np.cos(angles)[..., None] * m0 + np.sin(angles)[..., None] * side
    offsets = (normals @ np.asarray(result.centroid, np.float64))[..., None] + shifts
    return normals, offsets, votes


def supported_plane(
    result: Any, table_normal: np.ndarray, index: SupportIndex, support: float,
    config: CompletionConfig,
) -> tuple[np.ndarray, float, float] | None:  # fmt: skip
    """The near-best plane of the search the view supports best, if it beats the found one.

    Args:
        result: A single-view :class:`~symjax.symmetry.SymmetryResult`.
        table_normal: (3,) the table's unit normal.
        index: The view's :class:`SupportIndex`.
        support: The found plane's support.
        config: ``support_vote_ratio``, ``support_gain``, ``support_eps``.

    Returns:
        ``(normal (3,), offset, support)``, or None when no plane with a vote within
        ``support_vote_ratio`` of the best has a support of at least ``support +
        support_gain``.
    """
    normals, offsets, votes = grid_planes(result, table_normal)
    votes = np.where(np.isfinite(votes), votes, np.inf)
    best = float(votes.min())
    if not np.isfinite(best):
        return None
    near = np.argwhere(votes <= max(best * config.support_vote_ratio, best))
    found = None
    for i, j, k in near:
        s = index.support(normals[i, j], float(offsets[i, j, k]), config.support_eps)
        if found is None or s > found[2]:
            found = (normals[i, j], float(offsets[i, j, k]), s)
    if found is None or found[2] < support + config.support_gain:
        return None
    return found
