"""``PlanArmTrajectory`` (paper Section IV-B): mink IK, straight-line approach and lift, OMPL
RRT-Connect transit, time parameterisation and verification by replay in C MuJoCo.

Example::

    from symjax import motion
    scene = motion.PlanningScene("uji", {"box": hulls}, target="box")
    plan = motion.plan_arm(scene, motion.GraspPose.from_poses(pregrasp, grasp))
    if plan.ok:
        report = motion.replay(plan, scene)
"""

from symjax.motion.arm_plan import SEGMENTS, STATUSES, ArmPlan, GraspPose, grasp_poses
from symjax.motion.config import MotionConfig
from symjax.motion.ik import ArmIK, IKResult
from symjax.motion.pick import StartInCollisionError, plan_arm, plan_arm_batch
from symjax.motion.planning_scene import PlanningScene
from symjax.motion.transit import TransitResult, plan_transit
from symjax.motion.verification import ReplayReport, replay, replay_model

__all__ = [
    "SEGMENTS",
    "STATUSES",
    "ArmIK",
    "ArmPlan",
    "GraspPose",
    "IKResult",
    "MotionConfig",
    "PlanningScene",
    "ReplayReport",
    "StartInCollisionError",
    "TransitResult",
    "grasp_poses",
    "plan_arm",
    "plan_arm_batch",
    "plan_transit",
    "replay",
    "replay_model",
]
