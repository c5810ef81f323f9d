"""Support of a symmetry plane: how much of the mirrored view lands on the view itself.

The paper names three cases for a mirrored point (Section II-A.4): it coincides with an observed
point (it supports the plane), it falls into occluded space (no information), or into space seen
empty (it contradicts the plane). Eq. 3 scores only the third. A plane that mirrors the view
mostly into occluded space is never contradicted, which is how a wrong plane can win the vote;
the first case tells it apart: on the benchmark, the support alone separates good from bad
planes with a ROC AUC of 0.79 where the vote reaches 0.65.
"""

from __future__ import annotations

import math

import numpy as np

from symjax.array_types import ArrayLike
from symjax.completion.config import CompletionConfig
from symjax.errors import EmptyInputError, ShapeError
from symjax.geometry import axis_rotation

__all__ = ["SupportIndex", "plane_support"]


class SupportIndex:
    """The observed points of one view in a k-d tree, with the seeded subset that is mirrored.

    Args:
        points: (N, 3) observed points, world frame, metres (N >= 1).
        samples: Points of the subset mirrored per plane (all when fewer).
        seed: Seed of the subset.

    Raises:
        ShapeError: ``points`` is not (N, 3).
        EmptyInputError: No finite point.
    """

    def __init__(self, points: ArrayLike, samples: int, seed: int = 0) -> None:
        from scipy.spatial import cKDTree

        p = np.asarray(points, np.float64)
        if p.ndim != 2 or p.shape[1] != 3:
            raise ShapeError(f"points must have shape (N, 3), got {p.shape}")
        p = p[np.all(np.isfinite(p), axis=1)]
        if len(p) == 0:
            raise EmptyInputError("plane support needs at least one finite observed point")
        self.tree = cKDTree(p)
        rng = np.random.default_rng(seed)
        self.subset = p if len(p) <= samples else p[rng.choice(len(p), samples, replace=False)]

    def support(self, normal: ArrayLike, offset: float, eps: float) -> float:
        """Share in [0, 1] of mirrored subset points with an observed point within ``eps`` m."""
        n = np.asarray(normal, np.float64)
        n = n / np.linalg.norm(n)
        q = self.subset - 2.0 * (self.subset @ n - float(offset))[:, None] * n
        d, _ = self.tree.query(q, k=1, distance_upper_bound=eps)
        return float(np.mean(np.isfinite(d)))

    def rival_support(
        self, normal: ArrayLike, offset: float, table_normal: ArrayLike, config: CompletionConfig
    ) -> float:
        """The best support of the planes turned about the table normal by
        ``config.rival_angles_deg`` around the point of the plane nearest the subset's centroid,
        each at 5 shifts within ``+- config.rival_shift``."""
        n = np.asarray(normal, np.float64)
        up = np.asarray(table_normal, np.float64)
        c = self.subset.mean(axis=0)
        pivot = c - (float(c @ n) - float(offset)) * n
        best = 0.0
        for deg in config.rival_angles_deg:
            r = axis_rotation(up, math.radians(deg)) @ n
            for s in np.linspace(-config.rival_shift, config.rival_shift, 5):
                best = max(best, self.support(r, float(r @ pivot) + s, config.support_eps))
        return best


def plane_support(
    points: ArrayLike, normal: ArrayLike, offset: float, config: CompletionConfig | None = None
) -> float:
    """Share of the mirrored view that lands on the observed view (paper's case i).

    Args:
        points: (N, 3) observed points, world frame, metres.
        normal: (3,) plane normal (normalised here).
        offset: Plane offset, metres (``{x : normal . x = offset}``).
        config: ``support_eps`` and ``support_samples`` (default :class:`CompletionConfig`).

    Returns:
        The support in [0, 1].

    Raises:
        ShapeError: ``points`` is not (N, 3) or the normal is not (3,).
        EmptyInputError: No finite point.
    """
    cfg = config or CompletionConfig()
    n = np.asarray(normal, np.float64)
    if n.shape != (3,) or not np.all(np.isfinite(n)) or np.linalg.norm(n) < 1e-12:
        raise ShapeError(f"normal must be a finite non-zero (3,) vector, got {n.tolist()}")
    return SupportIndex(points, cfg.support_samples).support(n, offset, cfg.support_eps)
