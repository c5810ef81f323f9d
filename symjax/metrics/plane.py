"""Error of a found symmetry plane against the true symmetry of an object."""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from symjax.array_types import ArrayLike
from symjax.errors import InvalidInputError, ShapeError

__all__ = ["plane_error"]


def plane_error(
    normal: ArrayLike,
    offset: float,
    *,
    planes: Sequence[tuple[Any, float]] = (),
    axis: tuple[Any, Any] | None = None,
    centre: Any = (0.0, 0.0, 0.0),
) -> tuple[float, float]:
    """Angle and offset error of a plane ``{x : normal . x = offset}`` against the truth.

    * Planar symmetry (``planes``): against the nearest true plane by angle, the angle between
      the normals (sign-free) and the found plane's distance from the point of the true plane
      nearest ``centre`` (so an offset error does not depend on where the world origin is).
    * Rotational symmetry (``axis``): every plane through the axis is true; the angle error is
      the found plane's tilt away from the axis, the offset error its distance from the axis
      point nearest ``centre``.

    Args:
        normal: (3,) found plane normal, world frame (normalised here).
        offset: Found plane offset, metres.
        planes: True planes as ``(normal (3,), offset)`` pairs.
        axis: True axis of revolution as ``(point (3,), direction (3,))``.
        centre: (3,) the object's centre, metres.

    Returns:
        ``(angle_deg, offset_m)``; ``(nan, nan)`` when there is neither a plane nor an axis.

    Raises:
        ShapeError: The normal is not (3,).
        InvalidInputError: The normal is zero or not finite.
    """
    n = np.asarray(normal, np.float64)
    if n.shape != (3,):
        raise ShapeError(f"plane normal must have shape (3,), got {n.shape}")
    nn = float(np.linalg.norm(n))
    if not math.isfinite(nn) or nn < 1e-12:
        raise InvalidInputError(f"plane normal must be finite and non-zero, got {n.tolist()}")
    n = n / nn
    off = float(offset) / nn
    centre = np.asarray(centre, np.float64)
    if axis is not None:
        a, d = (np.asarray(x, np.float64) for x in axis)
        d = d / np.linalg.norm(d)
        tilt = math.degrees(math.asin(min(1.0, abs(float(n @ d)))))
        p = a + float((centre - a) @ d) * d
        return tilt, abs(float(n @ p) - off)
    best: tuple[float, float] | None = None
    for tn, to in planes:
        tn = np.asarray(tn, np.float64)
        tn = tn / np.linalg.norm(tn)
        ang = math.degrees(math.acos(min(1.0, abs(float(n @ tn)))))
        p = centre - (float(tn @ centre) - float(to)) * tn
        err = (ang, abs(float(n @ p) - off))
        if best is None or err[0] < best[0]:
            best = err
    return best if best is not None else (float("nan"), float("nan"))
