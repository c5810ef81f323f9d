"""Grasp planning (paper Section IV-A): candidate generation, rollouts, quality, ranking."""

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
from symjax.grasp.outcomes import GraspOutcomes
from symjax.grasp.plan import GraspPlan, plan, rank
from symjax.grasp.quality import contact_quality, epsilon_l1, force_closure, primitive_wrenches
from symjax.grasp.sim_config import SimulationConfig
from symjax.grasp.simulate import BACKENDS, GraspScene, build_scene, default_backend, simulate

__all__ = [
    "BACKENDS",
    "METHODS",
    "PINCH",
    "CandidateConfig",
    "CandidateSet",
    "Candidates",
    "GraspOutcomes",
    "GraspPlan",
    "GraspScene",
    "SimulationConfig",
    "approach_frame",
    "build_scene",
    "contact_quality",
    "default_backend",
    "epsilon_l1",
    "force_closure",
    "generate",
    "inside_mesh",
    "kth_grasp_points",
    "plan",
    "primitive_wrenches",
    "rank",
    "ray_mesh",
    "roll_for_axis",
    "simulate",
]
