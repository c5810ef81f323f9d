"""Grasp planning (paper Section IV-A): candidate generation, rollouts, quality, ranking.

Modules: ``config`` and ``sim_config`` (settings), ``candidate_set`` (the batch types),
``approach`` (TCP frames), ``mesh_rays`` (ray casting, inside test), ``candidates`` (the
generators), ``scene`` (the MjSpec grasp scene), ``schedule`` (open-loop inputs), ``labels``,
``backends`` (MJX and C MuJoCo), ``rollout`` (:func:`simulate`), ``quality`` (closure, epsilon),
``outcomes``, ``robustness`` (perturbed hand poses), ``planner`` (:func:`plan`, :func:`rank`,
:func:`robust_scores`).
"""

from symjax.grasp.approach import approach_frame, roll_for_axis
from symjax.grasp.backends import BACKENDS, default_backend
from symjax.grasp.candidate_set import Candidates, CandidateSet
from symjax.grasp.candidates import METHODS, generate, kth_grasp_points, start_pose_check
from symjax.grasp.config import PINCH, CandidateConfig
from symjax.grasp.mesh_rays import cast_rays, inside_mesh, ray_mesh
from symjax.grasp.outcomes import GraspOutcomes
from symjax.grasp.planner import GraspPlan, plan, rank, robust_scores
from symjax.grasp.quality import contact_quality, epsilon_l1, force_closure, primitive_wrenches
from symjax.grasp.robustness import RobustnessConfig, perturbed_candidates, pose_robustness
from symjax.grasp.rollout import simulate
from symjax.grasp.scene import GraspScene, build_scene
from symjax.grasp.sim_config import SimulationConfig

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
    "RobustnessConfig",
    "SimulationConfig",
    "approach_frame",
    "build_scene",
    "cast_rays",
    "contact_quality",
    "default_backend",
    "epsilon_l1",
    "force_closure",
    "generate",
    "inside_mesh",
    "kth_grasp_points",
    "perturbed_candidates",
    "plan",
    "pose_robustness",
    "primitive_wrenches",
    "rank",
    "robust_scores",
    "ray_mesh",
    "roll_for_axis",
    "simulate",
    "start_pose_check",
]
