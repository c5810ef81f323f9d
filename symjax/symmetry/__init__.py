"""Planar reflection symmetry perpendicular to the table (paper Section II-A)."""

from symjax.symmetry.config import SymmetryConfig
from symjax.symmetry.search import (
    SymmetryResult,
    ViewArrays,
    complete,
    prepare_view,
    reflect,
    score_planes,
    search,
    search_batch,
)

__all__ = [
    "SymmetryConfig",
    "SymmetryResult",
    "ViewArrays",
    "complete",
    "prepare_view",
    "reflect",
    "score_planes",
    "search",
    "search_batch",
]
