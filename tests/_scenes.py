"""Test-side names for the synthetic primitive views of :mod:`symjax.datasets.primitives`."""

from __future__ import annotations

from symjax.datasets.primitives import K_DEFAULT, plane_error, primitive_shape, primitive_view

shape = primitive_shape
view = primitive_view

__all__ = ["K_DEFAULT", "plane_error", "shape", "view"]
