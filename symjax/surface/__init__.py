"""Surface reconstruction of completed clouds (paper Section II-B) and the Delaunay baseline.

A completed view is meshed in two calls: :func:`oriented_completion` (outlier filter, normals
oriented by the mirrored viewpoint) then :func:`poisson_reconstruct` (or
:func:`poisson_reconstruct_batch` for many views in one jitted solve). Modules: ``config``,
``normals``, ``poisson`` (entry points), ``poisson_grid`` (the solver), ``isosurface``
(marching cubes), ``delaunay`` (the paper's baseline).
"""

from symjax.surface.config import DelaunayConfig, NormalsConfig, PoissonConfig
from symjax.surface.delaunay import delaunay_mesh
from symjax.surface.normals import (
    OrientedPoints,
    estimate_normals,
    oriented_completion,
    oriented_observation,
    outlier_mask,
)
from symjax.surface.poisson import poisson_reconstruct, poisson_reconstruct_batch

__all__ = [
    "DelaunayConfig",
    "NormalsConfig",
    "OrientedPoints",
    "PoissonConfig",
    "delaunay_mesh",
    "estimate_normals",
    "oriented_completion",
    "oriented_observation",
    "outlier_mask",
    "poisson_reconstruct",
    "poisson_reconstruct_batch",
]
