"""Grasp planning: candidate generation (paper Section IV-A)."""

from symjax.grasp.candidates import (
    METHODS,
    Candidates,
    CandidateSet,
    approach_frame,
    generate,
    inside_mesh,
    kth_grasp_points,
    ray_mesh,
    roll_for_axis,
)
from symjax.grasp.config import PINCH, CandidateConfig

__all__ = [
    "METHODS",
    "PINCH",
    "CandidateConfig",
    "CandidateSet",
    "Candidates",
    "approach_frame",
    "generate",
    "inside_mesh",
    "kth_grasp_points",
    "ray_mesh",
    "roll_for_axis",
]
