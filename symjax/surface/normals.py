"""Oriented normals of a (completed) point cloud by k-nearest-neighbour plane fits.

Paper Section II-B: the completed cloud is meshed by Poisson reconstruction, which needs oriented
normals. Each normal is the direction of least variance of the point's ``k`` nearest neighbours,
flipped towards the viewpoint that saw the point: the camera for observed points and the camera
mirrored across the symmetry plane for mirrored points (a mirrored point was "seen" by the
mirrored camera).
"""

from __future__ import annotations

import dataclasses
from typing import Any

import jax
import numpy as np

from symjax.array_types import ArrayLike
from symjax.errors import DegenerateGeometryError, EmptyInputError, InvalidInputError, ShapeError
from symjax.surface.config import NormalsConfig

__all__ = [
    "OrientedPoints",
    "check_not_degenerate",
    "estimate_normals",
    "oriented_completion",
    "outlier_mask",
]


@dataclasses.dataclass(frozen=True)
class OrientedPoints:
    """Points with oriented unit normals and per-point weights, ready for meshing.

    Attributes:
        points: (M, 3) world points, metres.
        normals: (M, 3) unit normals pointing out of the object (towards the viewpoint).
        weights: (M,) non-negative weights (plausibility of mirrored points, 1 for observed).
        mirrored: (M,) True for points that come from the mirroring.
    """

    points: np.ndarray
    normals: np.ndarray
    weights: np.ndarray
    mirrored: np.ndarray

    def __len__(self) -> int:
        return int(self.points.shape[0])


def _as_points(points: Any, what: str = "points") -> np.ndarray:
    p = np.asarray(points, dtype=np.float64)
    if p.ndim != 2 or p.shape[1] != 3:
        raise ShapeError(f"{what} must have shape (N, 3), got {p.shape}")
    if not np.all(np.isfinite(p)):
        raise InvalidInputError(f"{what} contain NaN or inf; expected finite coordinates (metres)")
    return p


def check_not_degenerate(points: np.ndarray, min_points: int, allow_planar: bool = False) -> None:
    """Raises when a cloud is too small, collinear or (unless allowed) coplanar.

    Args:
        points: (N, 3) finite points, metres.
        min_points: Smallest accepted N.
        allow_planar: Accept coplanar clouds (a plane has well-defined normals but no volume).

    Raises:
        EmptyInputError: If N < ``min_points``.
        DegenerateGeometryError: If the points are (nearly) collinear, or coplanar when
            ``allow_planar`` is False.
    """
    n = points.shape[0]
    if n < min_points:
        raise EmptyInputError(f"need at least {min_points} points, got {n}")
    s = np.linalg.svd(points - points.mean(axis=0), compute_uv=False) / np.sqrt(n)
    # Relative to the largest spread, with an absolute floor for float32 round-off.
    tol = max(1e-4 * s[0], 1e-7)
    if s[0] <= 1e-7 or s[1] <= tol:
        raise DegenerateGeometryError(
            f"the {n} points are collinear (principal spreads {s[0]:.3g}, {s[1]:.3g}, {s[2]:.3g} "
            "m); expected a surface patch"
        )
    if not allow_planar and s[2] <= tol:
        raise DegenerateGeometryError(
            f"the {n} points are coplanar (principal spreads {s[0]:.3g}, {s[1]:.3g}, {s[2]:.3g} "
            "m); a closed surface needs points that span a volume"
        )


def outlier_mask(points: ArrayLike, config: NormalsConfig | None = None) -> np.ndarray:
    """Statistical outlier filter: True for points to keep.

    A point is an outlier when the mean distance to its ``config.outlier_k`` nearest neighbours
    exceeds the cloud's mean of that distance by ``config.outlier_std`` standard deviations.

    Args:
        points: (N, 3) points, metres.
        config: Normal estimation configuration.

    Returns:
        (N,) boolean mask of inliers.
    """
    config = config or NormalsConfig()
    p = _as_points(points)
    if config.outlier_k == 0 or p.shape[0] <= config.outlier_k + 1:
        return np.ones(p.shape[0], dtype=bool)
    d, _ = _knn(p, config.outlier_k + 1)
    return _inliers(d, config)


def _knn(p: np.ndarray, k: int) -> tuple[np.ndarray, np.ndarray]:
    """Distances and indices (N, k) of each point's k nearest neighbours (itself first)."""
    from scipy.spatial import cKDTree

    return cKDTree(p).query(p, k=k, workers=-1)


def _inliers(d: np.ndarray, cfg: NormalsConfig) -> np.ndarray:
    """Statistical outlier test on kNN distances d (N, >= outlier_k + 1)."""
    mean_d = d[:, 1 : cfg.outlier_k + 1].mean(axis=1)
    return mean_d <= mean_d.mean() + cfg.outlier_std * mean_d.std()


def _plane_normals(p: np.ndarray, idx: np.ndarray, viewpoints) -> np.ndarray:
    """Least-variance directions (N, 3) of the neighbourhoods idx (N, k), flipped to face
    viewpoints ((3,) or (N, 3); None leaves the sign arbitrary)."""
    nb = p[idx]
    nb = nb - nb.mean(axis=1, keepdims=True)
    normals = np.linalg.eigh(np.matmul(nb.transpose(0, 2, 1), nb))[1][:, :, 0]
    if viewpoints is not None:
        flip = np.einsum("ni,ni->n", normals, viewpoints - p) < 0
        normals = np.where(flip[:, None], -normals, normals)
    return normals


def estimate_normals(
    points: ArrayLike, viewpoints: Any = None, config: NormalsConfig | None = None
) -> np.ndarray:
    """Unit normals by a plane fit to each point's k nearest neighbours.

    Args:
        points: (N, 3) points, metres.
        viewpoints: Where each point was seen from: (3,) for all points or (N, 3) per point,
            metres. Each normal is flipped to face its viewpoint; None leaves the sign arbitrary.
        config: Configuration (``config.k`` neighbours, the point itself included).

    Returns:
        (N, 3) unit normals.

    Raises:
        EmptyInputError: With fewer than ``config.k`` points.
        DegenerateGeometryError: If the cloud is collinear.
    """
    config = config or NormalsConfig()
    p = _as_points(points)
    check_not_degenerate(p, max(config.k, 3), allow_planar=True)
    vp = None
    if viewpoints is not None:
        vp = np.asarray(viewpoints, dtype=np.float64)
        if vp.shape not in ((3,), p.shape):
            raise ShapeError(f"viewpoints must have shape (3,) or {p.shape}, got {vp.shape}")
        vp = np.broadcast_to(vp, p.shape)
    _, idx = _knn(p, config.k)
    return _plane_normals(p, idx, vp)


def oriented_completion(result: Any, camera: Any, config: NormalsConfig | None = None):
    """Oriented normals of one completed cloud from the symmetry search.

    Observed points face the camera, mirrored points face the camera mirrored across the
    symmetry plane; outliers are removed. One k-d tree query serves both the outlier test and the
    plane fits (an outlier is far from everything, so it hardly ever enters an inlier's fit).

    Args:
        result: A single-view :class:`~symjax.symmetry.SymmetryResult`.
        camera: The :class:`~symjax.camera.Camera` that took the view.
        config: Normal estimation configuration.

    Returns:
        :class:`OrientedPoints` with the plausibility as weights (1 for observed points).
    """
    from symjax.symmetry import reflect

    if np.ndim(result.points) != 2:
        raise ShapeError("oriented_completion() needs one view; index the batch first: result[i]")
    config = config or NormalsConfig()
    # On the host: the result's concatenations of device arrays would be eager JAX calls, a
    # program each to fetch from the compilation cache (a tenth of a new process's first view).
    result = jax.device_get(result)
    pts = np.asarray(result.completed_points, dtype=np.float64)
    keep = np.asarray(result.completed_valid, dtype=bool)
    w = np.asarray(result.completed_plausibility, dtype=np.float64)
    n_obs = np.shape(result.points)[0]
    mirrored = np.arange(pts.shape[0]) >= n_obs
    pts, w, mirrored = pts[keep], w[keep], mirrored[keep]
    if pts.shape[0] == 0:
        raise EmptyInputError("the completed cloud has no valid points")
    check_not_degenerate(pts, max(config.k, config.outlier_k + 1, 3), allow_planar=True)
    cam = np.asarray(camera.position, dtype=np.float64)
    plane_n = np.asarray(result.normal, dtype=np.float64)
    cam_m = np.asarray(reflect(cam[None, :], plane_n, float(result.offset)))[0]
    vp = np.where(mirrored[:, None], cam_m[None, :], cam[None, :])
    return _oriented(pts, vp, w, mirrored, config)


def _oriented(pts, viewpoints, weights, mirrored, config: NormalsConfig) -> OrientedPoints:
    """Normals facing each point's viewpoint and the outliers removed; one k-d tree query
    serves both."""
    d, idx = _knn(pts, max(config.k, config.outlier_k + 1))
    normals = _plane_normals(pts, idx[:, : config.k], viewpoints)
    inl = _inliers(d, config) if config.outlier_k > 0 else np.ones(pts.shape[0], bool)
    return OrientedPoints(pts[inl], normals[inl], weights[inl], mirrored[inl])


def oriented_observation(points: ArrayLike, camera: Any, config: NormalsConfig | None = None):
    """Oriented normals of an observed (partial) cloud alone, without a symmetry result.

    Every point faces the camera that saw it; outliers are removed. For the baseline "mesh the
    observed points only" and for objects whose symmetry search failed.

    Args:
        points: (N, 3) observed points, world frame, metres.
        camera: The :class:`~symjax.camera.Camera` (or its position (3,), metres).
        config: Normal estimation configuration.

    Returns:
        :class:`OrientedPoints` with unit weights (none mirrored).
    """
    config = config or NormalsConfig()
    pts = _as_points(points)
    check_not_degenerate(pts, max(config.k, config.outlier_k + 1, 3), allow_planar=True)
    cam = np.asarray(getattr(camera, "position", camera), dtype=np.float64)
    if cam.shape != (3,) or not np.all(np.isfinite(cam)):
        raise ShapeError(f"camera must be a Camera or a finite position (3,), got {cam.shape}")
    n = len(pts)
    return _oriented(pts, np.broadcast_to(cam, pts.shape), np.ones(n), np.zeros(n, bool), config)
