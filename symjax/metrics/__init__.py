"""Mesh comparison metrics of the paper's evaluation (Section V-A.3 and V-B)."""

from symjax.metrics.centroid import centroid_error, surface_centroid
from symjax.metrics.deviation import Deviation, mesh_deviation, sample_surface, surface_distance

__all__ = [
    "Deviation",
    "centroid_error",
    "mesh_deviation",
    "sample_surface",
    "surface_centroid",
    "surface_distance",
]
