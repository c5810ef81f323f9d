"""Test-side names for the synthetic primitive views of :mod:`symjax.datasets.primitives`."""

from __future__ import annotations

from symjax.datasets.primitives import K_DEFAULT, primitive_shape, primitive_view, symmetry_truth
from symjax.metrics import plane_error as _plane_error

shape = primitive_shape
view = primitive_view


def plane_error(normal, offset, true_normals) -> tuple[float, float]:
    """Plane error of a found plane against a primitive's true planes (or its axis)."""
    return _plane_error(normal, offset, **symmetry_truth(true_normals))


__all__ = ["K_DEFAULT", "plane_error", "shape", "view"]
