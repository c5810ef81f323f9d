"""Settings of the grasp cycle (paper Algorithm 1): what shape the planners see, how often to
try, and the configs of the stages it chains."""

from __future__ import annotations

import dataclasses
from typing import Literal

from symjax.configs.stages import ShapeToGraspStages
from symjax.errors import ConfigError
from symjax.motion.config import MotionConfig
from symjax.perception.config import SegmentationConfig
from symjax.validation import check_fields

__all__ = ["MODES", "STAGES", "CycleConfig"]

#: What the planners see of each object: ``C`` the symmetry completion (Poisson, the paper's
#: Mir7), ``K`` the completion's plausible shapes (:func:`symjax.completion.plausible_shapes`;
#: grasps ranked across them, the arm planned on the first), ``P`` the observed points alone
#: (the paper's Delaunay baseline), ``T`` the true mesh (an oracle; needs a simulated scene).
MODES = ("C", "K", "P", "T")

#: The paper's functions of Algorithm 1, in order.
STAGES = (
    "GetObjectHypotheses",
    "PredictObjectShape",
    "ConvexDecomposition",
    "GetGraspCandidates",
    "PlanGrasp",
    "PlanArmTrajectory",
    "ExecuteGrasp",
)


@dataclasses.dataclass(frozen=True)
class CycleConfig(ShapeToGraspStages):
    """Parameters of :func:`symjax.cycle.clear_table`.

    Attributes:
        mode: One of :data:`MODES`.
        arm_grasps: Most stable grasps handed to ``PlanArmTrajectory`` per object, best first
            (the first that plans is executed); 0 = all of them, as Algorithm 1 loops.
        attempts_per_object: Executions of one object before the cycle gives up on it (a failed
            pick may leave it where it can be grasped again).
        dropoff_radius: An object is cleared when the hand releases it this close to the
            robot's drop-off point (horizontal distance; a bin beside the table) and it falls
            off the table, metres.
        min_match: Share of a hypothesis's pixels that must belong to one true object for the
            execution to know which object it picks (simulated scenes).
        backend: Grasp rollout backend (``"mujoco"``, ``"mjx"``, ``"mjx_warp"`` or None: by device).
        seed: Seed of the stereo noise of the frames taken after each pick.
        cache_dir: Cache of the preprocessed scans of a simulated scene (see
            :func:`symjax.datasets.load_object`; None = the default).
        segmentation, motion: Perception's and the arm's configs; the others are
            :class:`~symjax.configs.stages.ShapeToGraspStages`' (Poisson at the Mir7 depth).
    """

    mode: Literal["C", "K", "P", "T"] = "C"
    arm_grasps: int = 0
    attempts_per_object: int = 2
    dropoff_radius: float = 0.2
    min_match: float = 0.5
    backend: Literal["mujoco", "mjx", "mjx_warp"] | None = None
    seed: int = 0
    cache_dir: str | None = None
    segmentation: SegmentationConfig = dataclasses.field(default_factory=SegmentationConfig)
    motion: MotionConfig = dataclasses.field(default_factory=MotionConfig)

    def __post_init__(self) -> None:
        check_fields(self)
        if self.mode not in MODES:
            raise ConfigError(f"CycleConfig.mode = {self.mode!r}; expected one of C, K, P, T")
        if self.arm_grasps < 0 or self.attempts_per_object < 1:
            raise ConfigError(
                f"CycleConfig.arm_grasps = {self.arm_grasps} must be >= 0 (0 = all) and"
                f" attempts_per_object = {self.attempts_per_object} >= 1"
            )
        if not self.dropoff_radius > 0 or not 0 < self.min_match <= 1:
            raise ConfigError(
                f"CycleConfig.dropoff_radius = {self.dropoff_radius} must be > 0 and min_match ="
                f" {self.min_match} in (0, 1]"
            )
