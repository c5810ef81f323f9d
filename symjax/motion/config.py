"""Settings of ``PlanArmTrajectory`` (paper Section IV-B): IK, approach, transit and timing."""

from __future__ import annotations

import dataclasses
import math

from symjax.errors import ConfigError
from symjax.validation import check_fields

__all__ = ["MotionConfig"]


@dataclasses.dataclass(frozen=True)
class MotionConfig:
    """Parameters of :func:`symjax.motion.plan_arm`.

    Attributes:
        position_tolerance: IK converged when the TCP is within this of its target, metres.
        orientation_tolerance: ...and turned less than this from it, radians (1 deg).
        ik_iterations: Most differential-IK steps per seed.
        ik_restarts: Seeds tried before a pose is declared unreachable: the start
            configuration, home, then random configurations within the joint limits.
        ik_dt: Integration step of the differential IK, seconds (mink's ``dt``).
        ik_damping: Levenberg-Marquardt damping of the IK least squares.
        posture_cost: Weight of the posture task towards home (picks elbow-up solutions).
        clearance: Distance kept from the table and obstacles by mink's collision-avoidance
            limit during IK and the Cartesian motions, metres.
        detection_distance: The collision-avoidance limit looks at geom pairs closer than this,
            metres.
        check_margin: A configuration collides when a robot geom comes closer than this to the
            table, an obstacle or another robot link (OMPL's validity check), metres.
        carried_margin: The same for a held object against the table and the other objects:
            larger, since the object may slip or swing in the hand while it is carried, metres.
        obstacle_margin: The same for the robot against an object other than the target (at
            least ``check_margin``), metres: the shapes planned on are estimates (a completion,
            observed points) and the executed motion lags the plan by millimetres (a finger
            grazed a completed neighbour in the grasp cycle at 5 mm).
        approach_margin: The margin and the clearance of the last straight line to the grasp
            and of the fingers' closing sweep, metres (at most ``check_margin``): a low object
            is grasped with the fingertips just above the table.
        cartesian_step: Spacing of the waypoints of a straight-line TCP motion, metres.
        cartesian_iterations: Most IK steps per waypoint.
        cartesian_tolerance: A straight-line motion fails when the TCP ends farther than this
            from its goal (the collision-avoidance limit stopped it), metres.
        lift_height: Lift after the grasp, along the table normal, metres (paper: 10 cm).
        planner_time: RRT-Connect time limit per query, seconds.
        planner_range: RRT-Connect extension length in joint space, radians.
        resolution: Joint-space step of OMPL's own motion checks while it searches, radians.
        check_step: The straight lines and the found paths are checked again so densely that no
            robot point moves farther than this between two checks, metres (below
            ``check_margin``, so that nothing passes through a thin obstacle between checks).
        simplify_time: Path shortcutting on (> 0) or off (0): OMPL's ``simplifyMax``, which is
            bounded by iterations, not time, so that a plan repeats on a loaded CPU.
        velocity_scale: Fraction of the arm's joint speed limits the trajectory uses.
        acceleration_scale: Fraction of its acceleration limits.
        carry_scale: Further fraction of both while the object is held (lift, transfer): a
            grasp tested by a lift and a shake can still slip under the arm's full accelerations.
        sample_dt: Spacing of the trajectory samples, seconds.
        close_time: Hand closing, seconds.
        release_time: Hand opening at the drop-off, seconds: the command opens in the first
            third, the fingers then finish opening before the return.
        seed: Seed of the IK restarts.
    """

    position_tolerance: float = 1e-3
    orientation_tolerance: float = math.radians(1.0)
    ik_iterations: int = 150
    ik_restarts: int = 6
    ik_dt: float = 0.1
    ik_damping: float = 1e-3
    posture_cost: float = 1e-3
    clearance: float = 0.005
    detection_distance: float = 0.05
    check_margin: float = 0.005
    obstacle_margin: float = 0.01
    approach_margin: float = 0.005
    carried_margin: float = 0.02
    cartesian_step: float = 0.01
    cartesian_iterations: int = 20
    cartesian_tolerance: float = 0.005
    lift_height: float = 0.10
    planner_time: float = 1.0
    planner_range: float = 0.5
    resolution: float = 0.02
    check_step: float = 0.004
    simplify_time: float = 0.05
    velocity_scale: float = 0.5
    acceleration_scale: float = 0.5
    carry_scale: float = 0.5
    sample_dt: float = 0.01
    close_time: float = 1.0
    release_time: float = 1.5
    seed: int = 0

    def __post_init__(self) -> None:
        check_fields(self)
        positive = (
            "position_tolerance", "orientation_tolerance", "ik_iterations", "ik_dt",
            "detection_distance", "cartesian_step", "cartesian_iterations",
            "cartesian_tolerance", "planner_time", "planner_range", "resolution",
            "check_step", "sample_dt", "close_time", "release_time",
        )  # fmt: skip
        for name in positive:
            if not getattr(self, name) > 0:
                raise ConfigError(f"{name} = {getattr(self, name)!r}; expected > 0")
        for name in ("ik_restarts", "ik_damping", "posture_cost", "clearance", "check_margin",
                     "carried_margin", "lift_height", "simplify_time"):  # fmt: skip
            if getattr(self, name) < 0:
                raise ConfigError(f"{name} = {getattr(self, name)!r}; expected >= 0")
        for name in ("velocity_scale", "acceleration_scale", "carry_scale"):
            if not 0 < getattr(self, name) <= 1:
                raise ConfigError(f"{name} = {getattr(self, name)!r}; expected in (0, 1]")
        if self.obstacle_margin < self.check_margin:
            raise ConfigError(
                f"obstacle_margin = {self.obstacle_margin} must be >= check_margin ="
                f" {self.check_margin} (metres)"
            )
        if not 0 <= self.approach_margin <= self.check_margin:
            raise ConfigError(
                f"approach_margin = {self.approach_margin} must be in [0, check_margin ="
                f" {self.check_margin}] (metres)"
            )
        if self.detection_distance <= self.clearance:
            raise ConfigError(
                f"detection_distance = {self.detection_distance} must exceed clearance ="
                f" {self.clearance} (metres)"
            )
