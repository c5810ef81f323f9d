"""The table plane: RANSAC with all hypotheses scored in one jitted vmap, then least squares."""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np

from symjax.array_types import ArrayLike
from symjax.errors import DegenerateGeometryError, EmptyInputError, ShapeError
from symjax.perception.config import SegmentationConfig
from symjax.table import TablePlane

__all__ = ["fit_table_plane", "plane_costs", "ransac_plane", "subsample"]


def _plane_cost(sample, triple, threshold, up, cos_min):
    """MSAC cost of the plane through ``sample[triple]`` (one hypothesis).

    Args:
        sample: (S, 3) points, metres.
        triple: (3,) int indices into ``sample``.
        threshold: Truncation distance, metres.
        up: (3,) unit direction the normal must be near.
        cos_min: Smallest allowed ``|n . up|`` (0 accepts every plane).

    Returns:
        ``(cost, normal (3,), offset)``; cost is inf for a degenerate or too tilted triple.
    """
    a, b, c = sample[triple[0]], sample[triple[1]], sample[triple[2]]
    n = jnp.cross(b - a, c - a)
    norm = jnp.linalg.norm(n)
    ok = norm > 1e-9
    n = n / jnp.where(ok, norm, 1.0)
    d = -jnp.dot(n, a)
    r = sample @ n + d
    cost = jnp.sum(jnp.minimum(r * r, threshold * threshold))
    ok = ok & (jnp.abs(jnp.dot(n, up)) >= cos_min)
    return jnp.where(ok, cost, jnp.inf), n, d


@jax.jit
def plane_costs(
    sample: jax.Array, triples: jax.Array, threshold: float, up: jax.Array, cos_min: float
) -> jax.Array:
    """Scores all hypotheses at once.

    Args:
        sample: (S, 3) float32 points.
        triples: (M, 3) int32 point indices per hypothesis.
        threshold: MSAC truncation distance, metres (scalar).
        up: (3,) unit direction; cos_min: smallest ``|n . up|`` (scalar, 0 = any plane).

    Returns:
        ``(costs (M,), normals (M, 3), offsets (M,))``.
    """
    return jax.vmap(_plane_cost, in_axes=(None, 0, None, None, None))(
        sample, triples, threshold, up, cos_min
    )


def _refine(points: np.ndarray, n: np.ndarray, d: float, threshold: float, iterations: int):
    for _ in range(iterations):
        q = points[np.abs(points @ n.astype(np.float32) + np.float32(d)) < threshold]
        if len(q) < 3:
            break
        q = q.astype(np.float64)
        c = q.mean(axis=0)
        # The smallest principal axis of the inliers is the least-squares normal.
        _, v = np.linalg.eigh((q - c).T @ (q - c))
        m = v[:, 0]
        n, d = (m, -float(m @ c)) if m @ n >= 0 else (-m, float(m @ c))
    return n, d


def ransac_plane(
    sample: np.ndarray,
    refine: np.ndarray,
    config: SegmentationConfig,
    viewpoint: ArrayLike = None,
    rng: np.random.Generator | None = None,
) -> TablePlane:
    """RANSAC on ``sample``, least-squares refinement on ``refine``.

    Args:
        sample: (config.ransac_sample, 3) float32 finite points the hypotheses are scored on.
        refine: (M, 3) float32 finite points of the refinement (a larger subsample).
        config: Settings.
        viewpoint: Optional sensor origin (3,) the normal is turned to face.
        rng: Random generator of the hypotheses (default: seeded by ``config.seed``).

    Raises:
        DegenerateGeometryError: No valid hypothesis, or fewer than ``min_table_fraction`` of the
            sample on the plane.
    """
    rng = rng or np.random.default_rng(config.seed)
    # Triples with a repeated index are degenerate and score inf: cheaper than sampling without
    # replacement per hypothesis.
    triples = rng.integers(0, len(sample), size=(config.ransac_hypotheses, 3), dtype=np.int32)
    if config.up is None:
        up, cos_min = np.array([0.0, 0.0, 1.0], np.float32), 0.0
    else:
        up = np.asarray(config.up, np.float32) / np.linalg.norm(config.up)
        cos_min = float(np.cos(config.max_tilt))
    costs, normals, offsets = plane_costs(
        sample, triples, np.float32(config.inlier_threshold), up, np.float32(cos_min)
    )
    costs = np.asarray(costs)
    best = int(np.argmin(costs))
    if not np.isfinite(costs[best]):
        raise DegenerateGeometryError(
            "no valid plane hypothesis (points collinear, or no plane within max_tilt of up)"
        )
    n = np.asarray(normals[best], np.float64)
    n, d = _refine(
        refine, n, float(offsets[best]), config.inlier_threshold, config.refine_iterations
    )
    if viewpoint is not None:
        if float(n @ np.asarray(viewpoint, np.float64)) + d < 0:
            n, d = -n, -d
    elif config.up is not None and float(n @ up) < 0:
        n, d = -n, -d
    frac = float(
        np.mean(np.abs(sample @ n.astype(np.float32) + np.float32(d)) < config.inlier_threshold)
    )
    if frac < config.min_table_fraction:
        raise DegenerateGeometryError(
            f"no table: the best plane holds {frac:.1%} of the points, expected at least "
            f"{config.min_table_fraction:.0%} (min_table_fraction)"
        )
    return TablePlane.create(n, d)


def fit_table_plane(
    points: ArrayLike, config: SegmentationConfig | None = None, viewpoint: ArrayLike = None
) -> tuple[TablePlane, np.ndarray]:
    """Finds the dominant plane of a cloud.

    Args:
        points: (N, 3) metres; non-finite rows are ignored.
        config: Settings (``ransac_*``, ``inlier_threshold``, ``up``, ``max_tilt``,
            ``min_table_fraction``, ``refine_sample``, ``seed``).
        viewpoint: Optional sensor origin (3,): the normal is turned to face it. Without it the
            normal faces ``config.up`` when given.

    Returns:
        ``(table, inliers)``: the plane and a bool (N,) mask of points within
        ``inlier_threshold`` of it.

    Raises:
        ShapeError: Points not (N, 3).
        EmptyInputError: Fewer than 3 finite points.
        DegenerateGeometryError: No plane with ``min_table_fraction`` of the points.
    """
    config = config or SegmentationConfig()
    p = np.asarray(points, dtype=np.float32)
    if p.ndim != 2 or p.shape[1] != 3:
        raise ShapeError(f"points must have shape (N, 3), got {p.shape}")
    finite = np.all(np.isfinite(p), axis=1)
    idx = np.flatnonzero(finite)
    if len(idx) < 3:
        raise EmptyInputError(f"need at least 3 finite points to fit a table, got {len(idx)}")
    rng = np.random.default_rng(config.seed)
    sample, refine = subsample(idx, config, rng)
    table = ransac_plane(p[sample], p[refine], config, viewpoint, rng)
    with np.errstate(invalid="ignore"):
        inliers = np.abs(table.height(p)) < config.inlier_threshold
    return table, inliers & finite


def subsample(
    idx: np.ndarray, config: SegmentationConfig, rng: np.random.Generator
) -> tuple[np.ndarray, np.ndarray]:
    """Indices of the RANSAC sample (``config.ransac_sample``, fixed size so that the kernel
    compiles once) and of the refinement subsample (at most ``config.refine_sample``) from
    ``idx``."""
    sample = rng.choice(idx, config.ransac_sample, replace=len(idx) < config.ransac_sample)
    refine = (
        idx if len(idx) <= config.refine_sample else rng.choice(idx, config.refine_sample, False)
    )
    return sample, refine
