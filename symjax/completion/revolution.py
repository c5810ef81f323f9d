"""Surfaces of revolution about the table normal: the axis fit and the completion by revolving.

A surface of revolution has every normal line crossing its axis. Seen along the table normal,
the normal line of a point ``p`` with horizontal normal ``n_h`` crosses the vertical axis at
``a`` when ``cross(n_h, a - p_h) = 0``, which is linear in ``a``: one least-squares solve gives
the axis, and the distances of the normal lines from it say how rotational the visible surface is
(a can or a cup: a few percent of its radius; a box: half of it, since the normal lines of a flat
face are parallel and cannot all meet one axis). Points whose normal is nearly vertical (a lid,
the table side of a rim) carry no information about the axis and are left out of the fit.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from symjax.array_types import ArrayLike
from symjax.completion.config import CompletionConfig
from symjax.errors import DegenerateGeometryError, ShapeError
from symjax.geometry import axis_rotation, tangent_basis
from symjax.surface.normals import OrientedPoints

__all__ = ["RevolutionFit", "fit_revolution", "profile_consistent", "revolve"]


@dataclasses.dataclass(frozen=True)
class RevolutionFit:
    """A vertical axis fitted to the normal lines of a visible surface.

    Attributes:
        point: (3,) the axis point in the table plane, world frame, metres.
        direction: (3,) the unit axis direction (the table normal).
        radius: Median distance of the fitted points from the axis, metres.
        residual: Median distance of the normal lines from the axis over ``radius``
            (dimensionless; 0 for an exact surface of revolution).
        n_used: Points whose normal was tilted enough from the axis to enter the fit.
        rotational: ``residual <= config.revolution_residual`` with enough points used.
    """

    point: np.ndarray
    direction: np.ndarray
    radius: float
    residual: float
    n_used: int
    rotational: bool


def fit_revolution(
    oriented: OrientedPoints, table_normal: ArrayLike, config: CompletionConfig | None = None
) -> RevolutionFit:
    """Fits the vertical axis whose surface of revolution best explains the oriented points.

    Args:
        oriented: Observed points (M, 3) with unit normals (M, 3), metres, world frame.
        table_normal: (3,) unit table normal; the axis is parallel to it.
        config: Thresholds (default :class:`CompletionConfig`).

    Returns:
        A :class:`RevolutionFit`; ``rotational`` is False (residual ``inf``) when too few
        normals are tilted away from the axis to fit one.

    Raises:
        ShapeError: The table normal is not (3,) or not a unit vector.
    """
    cfg = config or CompletionConfig()
    up = np.asarray(table_normal, np.float64)
    if up.shape != (3,) or not math.isclose(float(np.linalg.norm(up)), 1.0, abs_tol=1e-3):
        raise ShapeError(f"table_normal must be a unit vector (3,), got {up.tolist()}")
    e1, e2 = tangent_basis(up)
    p = np.asarray(oriented.points, np.float64)
    n = np.asarray(oriented.normals, np.float64)
    pu, pv = p @ e1, p @ e2
    nu, nv = n @ e1, n @ e2
    tilt = np.hypot(nu, nv)
    use = tilt >= cfg.revolution_min_tilt
    base = p.mean(axis=0) - float(p.mean(axis=0) @ up) * up if len(p) else np.zeros(3)
    if int(use.sum()) < cfg.revolution_min_points:
        return RevolutionFit(base, up, math.nan, math.inf, int(use.sum()), False)
    # cross(n_h, a - p_h) = 0  <=>  -nv * a_u + nu * a_v = nu * p_v - nv * p_u
    A = np.stack([-nv[use], nu[use]], axis=1)
    b = nu[use] * pv[use] - nv[use] * pu[use]
    ata = A.T @ A
    if np.linalg.cond(ata) > 1e8:  # parallel normal lines (one flat face): no axis
        return RevolutionFit(base, up, math.nan, math.inf, int(use.sum()), False)
    au, av = np.linalg.solve(ata, A.T @ b)
    dist = np.abs(A @ np.array([au, av]) - b) / tilt[use]
    radius = float(np.median(np.hypot(pu[use] - au, pv[use] - av)))
    residual = float(np.median(dist)) / max(radius, 1e-9)
    # The axis point on the table plane through the points' lowest height keeps it finite.
    point = au * e1 + av * e2 + float(np.min(p @ up)) * up
    ok = residual <= cfg.revolution_residual and radius > 0
    return RevolutionFit(point, up, radius, residual, int(use.sum()), bool(ok))


def profile_consistent(
    oriented: OrientedPoints, fit: RevolutionFit, tolerance: float
) -> np.ndarray:
    """(M,) bool: points whose distance from the axis matches the surface's radius profile.

    The profile is the median radius in height slabs of 5 % of the visible height. A handle
    or a spout stands out of it and is left out of the copies (kept once, where it was seen),
    so that revolving does not turn it into a ring.
    """
    p = np.asarray(oriented.points, np.float64) - fit.point
    h = p @ fit.direction
    r = np.linalg.norm(p - h[:, None] * fit.direction, axis=1)
    lo, hi = float(h.min()), float(h.max())
    slab = np.minimum(((h - lo) / max(hi - lo, 1e-9) * 20).astype(int), 19)
    profile = np.zeros(20)
    for k in np.unique(slab):
        profile[k] = np.median(r[slab == k])
    return np.abs(r - profile[slab]) <= np.maximum(tolerance, 0.15 * profile[slab])


def revolve(
    oriented: OrientedPoints, fit: RevolutionFit, copies: int, tolerance: float = 0.004
) -> OrientedPoints:
    """The oriented points, and ``copies - 1`` copies of their rotational part turned about the
    axis by ``2 pi k / copies``.

    Args:
        oriented: Observed oriented points (M, 3) with normals, weights.
        fit: The fitted axis.
        copies: Turns around the full circle (>= 2), the original included.
        tolerance: Points farther than this (metres, or 15 % of the local radius if more) from
            the radius profile are not copied (see :func:`profile_consistent`).

    Returns:
        :class:`OrientedPoints`, the observed points first; the turned points have ``mirrored``
        True.

    Raises:
        DegenerateGeometryError: ``copies < 2`` or the fit has no axis.
    """
    if copies < 2:
        raise DegenerateGeometryError(f"revolve needs copies >= 2, got {copies}")
    if not np.all(np.isfinite(fit.point)):
        raise DegenerateGeometryError("the revolution fit has no axis")
    keep = profile_consistent(oriented, fit, tolerance)
    p = np.asarray(oriented.points, np.float64) - fit.point
    n = np.asarray(oriented.normals, np.float64)
    w = np.asarray(oriented.weights, np.float64)
    pts, nrm, wts = [p], [n], [w]
    for k in range(1, copies):
        R = axis_rotation(fit.direction, 2.0 * math.pi * k / copies)
        pts.append(p[keep] @ R.T)
        nrm.append(n[keep] @ R.T)
        wts.append(w[keep])
    points = np.concatenate(pts) + fit.point
    return OrientedPoints(
        points=points,
        normals=np.concatenate(nrm),
        weights=np.concatenate(wts),
        mirrored=np.arange(len(points)) >= len(p),
    )
