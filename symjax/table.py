"""The supporting table plane."""

from __future__ import annotations

from typing import Any

import numpy as np

from symjax._pytree import pytree_dataclass
from symjax.array_types import ArrayLike
from symjax.errors import InvalidInputError, ShapeError

__all__ = ["TablePlane"]


@pytree_dataclass
class TablePlane:
    """The plane ``{x : normal . x + offset = 0}``.

    ``normal`` is unit and points up (to the camera).

    Attributes:
        normal: Unit normal, shape (3,).
        offset: Scalar offset, metres. The height of a point above the table is
            ``normal . x + offset``.
    """

    normal: Any
    offset: Any

    @classmethod
    def create(cls, normal: ArrayLike, offset: float) -> TablePlane:
        """Builds a validated plane; ``normal`` is normalised."""
        n = np.asarray(normal, dtype=np.float64)
        if n.shape != (3,):
            raise ShapeError(f"table normal must have shape (3,), got {n.shape}")
        norm = np.linalg.norm(n)
        if not np.isfinite(norm) or norm < 1e-9 or not np.isfinite(offset):
            raise InvalidInputError(f"table normal must be finite and non-zero, got {n}, {offset}")
        return cls(normal=n / norm, offset=np.float64(offset / norm))

    @classmethod
    def horizontal(cls, height: float = 0.0) -> TablePlane:
        """The plane z = ``height`` with normal +z (the usual table-aligned world frame)."""
        return cls.create((0.0, 0.0, 1.0), -float(height))

    @classmethod
    def from_point_normal(cls, point: Any, normal: ArrayLike) -> TablePlane:
        """The plane through ``point`` with ``normal``."""
        n = np.asarray(normal, dtype=np.float64)
        n = n / np.linalg.norm(n)
        return cls.create(n, -float(n @ np.asarray(point, dtype=np.float64)))

    def height(self, points):
        """Signed height (..., ) of points (..., 3) above the plane, metres."""
        return points @ self.normal + self.offset

    def transformed(self, T_new_world: ArrayLike) -> TablePlane:
        """The same plane after a rigid motion ``T_new_world`` (4, 4) of the world frame."""
        T = np.asarray(T_new_world, dtype=np.float64)
        n = T[:3, :3] @ np.asarray(self.normal)
        return TablePlane.create(n, float(self.offset) - float(n @ T[:3, 3]))
