"""Surface reconstruction of completed clouds (paper Section II-B) and the Delaunay baseline."""

from symjax.surface.config import DelaunayConfig, NormalsConfig, PoissonConfig
from symjax.surface.delaunay import delaunay_mesh
from symjax.surface.normals import (
    OrientedPoints,
    estimate_normals,
    oriented_completion,
    outlier_mask,
)
from symjax.surface.poisson import (
    PoissonGrid,
    grid_to_mesh,
    mesh_completion,
    mesh_completions,
    pack_views,
    poisson_grid,
    poisson_grids,
    poisson_reconstruct,
    poisson_reconstruct_batch,
)

__all__ = [
    "DelaunayConfig",
    "NormalsConfig",
    "OrientedPoints",
    "PoissonConfig",
    "PoissonGrid",
    "delaunay_mesh",
    "estimate_normals",
    "grid_to_mesh",
    "mesh_completion",
    "mesh_completions",
    "oriented_completion",
    "outlier_mask",
    "pack_views",
    "poisson_grid",
    "poisson_grids",
    "poisson_reconstruct",
    "poisson_reconstruct_batch",
]
