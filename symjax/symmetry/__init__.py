"""Planar reflection symmetry perpendicular to the table (paper Section II-A).

Modules: ``config`` (search parameters), ``view`` (a view packed for the kernels), ``scoring``
(Eq. 3 per plane), ``hypotheses`` (Eq. 1 start, the n x m grid, refinement, Eq. 4), ``result``,
``solver`` (the jitted entry points), ``scene`` (the objects of one frame searched together),
``reference`` (a numpy scorer for tests).
"""

from symjax.symmetry.config import SymmetryConfig
from symjax.symmetry.result import SymmetryResult
from symjax.symmetry.scene import search_scene
from symjax.symmetry.scoring import reflect, score_planes
from symjax.symmetry.solver import (
    complete,
    mirror_across,
    search,
    search_batch,
    search_or_errors,
)
from symjax.symmetry.view import ViewArrays, prepare_view

__all__ = [
    "SymmetryConfig",
    "SymmetryResult",
    "ViewArrays",
    "complete",
    "mirror_across",
    "prepare_view",
    "reflect",
    "score_planes",
    "search",
    "search_batch",
    "search_or_errors",
    "search_scene",
]
