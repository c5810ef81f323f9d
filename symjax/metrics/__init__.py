"""Mesh comparison metrics of the paper's evaluation (Section V-A.3 and V-B), and the error of
a found symmetry plane."""

from symjax.metrics.centroid import centroid_error, oriented_diagonal, surface_centroid
from symjax.metrics.deviation import Deviation, mesh_deviation, sample_surface, surface_distance
from symjax.metrics.plane import plane_error

__all__ = [
    "Deviation",
    "centroid_error",
    "mesh_deviation",
    "oriented_diagonal",
    "plane_error",
    "sample_surface",
    "surface_centroid",
    "surface_distance",
]
