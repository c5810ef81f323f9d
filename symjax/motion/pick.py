"""``PlanArmTrajectory`` (paper Section IV-B): transit, approach, close, lift, transfer, release,
return, for one grasp or the ranked stable grasps of an object.
"""

from __future__ import annotations

import time
from typing import Any

import numpy as np

from symjax.errors import InvalidInputError, config_or_default
from symjax.motion.arm_plan import ArmPlan, GraspPose, grasp_poses
from symjax.motion.closing import closing_contacts
from symjax.motion.config import MotionConfig
from symjax.motion.ik import ArmIK, tcp_error
from symjax.motion.planning_scene import PlanningScene
from symjax.motion.timing import time_path
from symjax.motion.transit import plan_transit

__all__ = ["StartInCollisionError", "plan_arm", "plan_arm_batch"]


class StartInCollisionError(InvalidInputError):
    """The robot's start configuration collides with the table, an object or itself."""


def _hand_env_contact(scene: PlanningScene, contacts) -> bool:
    """Whether some contact is between a hand geom and the table or an object."""
    prefix = scene.robot.hand_prefix
    env = ("table", "floor", "pedestal", "obj/")
    for a, b, _ in contacts:
        for h, o in ((a, b), (b, a)):
            if h.startswith(prefix) and o.startswith(env):
                return True
    return False


def _check_start(scene: PlanningScene, start: Any, preshape: int) -> np.ndarray:
    q0 = scene.full_q(scene.robot.home if start is None else start, preshape)
    n = scene.robot.n_arm
    lo, hi = scene.scene_model().model.jnt_range[:n].T
    out = np.flatnonzero((q0[:n] < lo - 1e-9) | (q0[:n] > hi + 1e-9))
    if len(out):
        j = int(out[0])
        raise InvalidInputError(
            f"start joint {j} is {q0[j]:.4f} rad, outside its range [{lo[j]:.4f}, {hi[j]:.4f}];"
            " expected a configuration within the joint limits"
        )
    # The robot is already there: only contacts within the plain margin stop it, not an object
    # within the wider obstacle margin (that margin is for the motions planned from here).
    col = scene.collisions(q0, obstacles=False)
    if col:
        pairs = ", ".join(f"{a}-{b} ({1e3 * d:.1f} mm)" for a, b, d in col[:4])
        raise StartInCollisionError(
            f"the start configuration is in collision: {pairs}; expected a collision-free"
            " configuration (move the robot or the objects)"
        )
    return q0


class _Builder:
    """Concatenates timed segments into one trajectory."""

    def __init__(self, scene: PlanningScene, config: MotionConfig):
        r = scene.robot
        self.n = r.n_arm
        self.vmax = np.asarray(r.velocity_limits) * config.velocity_scale
        self.amax = np.asarray(r.acceleration_limits) * config.acceleration_scale
        self.dt = config.sample_dt
        self.t: list[np.ndarray] = []
        self.q: list[np.ndarray] = []
        self.h: list[np.ndarray] = []
        self.segments: list[tuple[str, int, int]] = []
        self.count = 0
        self.t_end = 0.0

    def move(self, name: str, path: np.ndarray, hand: float, corners: bool,
             scale: float = 1.0) -> None:  # fmt: skip
        t, q = time_path(np.asarray(path)[:, : self.n], scale * self.vmax, scale * self.amax,
                         self.dt, corners)  # fmt: skip
        self._add(name, t, q, np.full(len(t), hand))

    def hold(self, name: str, q: np.ndarray, seconds: float, h0: float, h1: float,
             ramp: float = 1.0) -> None:  # fmt: skip
        """The arm still for ``seconds``; the hand command goes from h0 to h1 in the first
        ``ramp`` share of them and then holds."""
        t = np.arange(0.0, seconds + 1e-9, self.dt)
        s = np.clip(t / (ramp * seconds), 0.0, 1.0)
        self._add(name, t, np.repeat(q[None, : self.n], len(t), 0), h0 + (h1 - h0) * s)

    def _add(self, name, t, q, h) -> None:
        offset = self.t_end + (self.dt if self.count else 0.0)
        self.t.append(t + offset)
        self.q.append(q)
        self.h.append(h)
        self.segments.append((name, self.count, self.count + len(t)))
        self.count += len(t)
        self.t_end = float(offset + t[-1])

    def arrays(self):
        if not self.t:
            return np.zeros(0), np.zeros((0, self.n)), np.zeros(0)
        return np.concatenate(self.t), np.concatenate(self.q), np.concatenate(self.h)


def _plan(
    scene: PlanningScene,
    grasp: GraspPose,
    q0: np.ndarray,
    config: MotionConfig,
    ik: ArmIK,
) -> ArmPlan:
    target = scene.target
    nan = np.full(scene.robot.n_arm, np.nan)
    secs: dict[str, float] = {}
    planners: dict[str, str] = {}
    out = _Builder(scene, config)
    errs = {"pre": (np.nan, np.nan), "grasp": (np.nan, np.nan)}
    t_start = time.perf_counter()

    def done(status: str, reason: str = "", grasp_q=nan) -> ArmPlan:
        secs["total"] = time.perf_counter() - t_start
        t, q, h = out.arrays() if status == "ok" else (np.zeros(0), np.zeros((0, len(nan))),
                                                       np.zeros(0))  # fmt: skip
        return ArmPlan(status, reason, scene.robot.name, grasp, t, q, h,
                       tuple(out.segments) if status == "ok" else (), grasp_q,
                       errs["pre"], errs["grasp"], planners, secs, target)  # fmt: skip

    def clock(name: str, t0: float) -> None:
        secs[name] = secs.get(name, 0.0) + time.perf_counter() - t0

    # Pre-grasp IK: the target is an obstacle here, the hand must not touch it yet.
    t0 = time.perf_counter()
    p_pre, R_pre = grasp.pregrasp
    res = ik.solve(p_pre, R_pre, q0)
    clock("ik", t0)
    if not res.converged:
        if not res.reachable:
            return done("unreachable", "pre-grasp out of reach: IK stopped"
                        f" {1e3 * res.position_error:.1f} mm"
                        f" and {np.degrees(res.orientation_error):.2f} deg from it after"
                        f" {res.seeds} seeds")  # fmt: skip
        col = ", ".join(f"{a}-{b}" for a, b, _ in res.collisions[:3])
        if _hand_env_contact(scene, res.collisions):
            return done("start_in_collision", f"the hand collides at the pre-grasp pose: {col}")
        return done("ik_failed", f"every arm solution at the pre-grasp collides: {col}")
    q_pre = res.q
    errs["pre"] = tcp_error(scene, q_pre, p_pre, R_pre)

    t0 = time.perf_counter()
    tr = plan_transit(scene, q0, q_pre, config)
    clock("transit", t0)
    planners["transit"] = tr.planner
    if not tr.solved:
        return done("no_path", f"transit: {tr.reason}")
    out.move("transit", tr.path, 0.0, corners=True)

    # Approach: straight TCP line, the hand may touch the target (it ends there).
    t0 = time.perf_counter()
    p_g, R_g = grasp.grasp
    allow_t = (("hand", target),) if target else ()
    # The grasp may hold a low object with the fingertips just above the table: the last
    # straight line keeps the smaller approach margin (the replay counts real contacts).
    scene.table_margin = config.approach_margin
    try:
        path, ep, er, col = ik.line(q_pre, p_g, R_g, avoid=(target,) if target else (),
                                    allow=allow_t, table=config.approach_margin)  # fmt: skip
        hits = closing_contacts(scene, path[-1], grasp.preshape) if path else ()
    finally:
        scene.table_margin = None
    clock("approach", t0)
    contacts = ", ".join(f"{a}-{b}" for a, b, _ in col[:3])
    if not path:
        return done("ik_failed", f"the approach collides at once: {contacts}")
    q_g = path[-1]
    errs["grasp"] = tcp_error(scene, q_g, p_g, R_g)
    if errs["grasp"][0] > config.cartesian_tolerance:
        why = f"a contact ahead: {contacts}" if col else "the collision limit or a joint limit"
        return done("ik_failed", f"approach stopped {1e3 * errs['grasp'][0]:.1f} mm from the"
                    f" grasp pose ({why})", q_g[: len(nan)])  # fmt: skip
    if hits:
        pairs = ", ".join(f"{a}-{b}" for a, b, _ in hits[:3])
        return done("start_in_collision", f"the closing fingers hit the clutter: {pairs}",
                    q_g[: len(nan)])  # fmt: skip
    out.move("approach", np.concatenate([q_pre[None], np.stack(path)]), 0.0, corners=False)
    out.hold("close", q_g, config.close_time, 0.0, 1.0)

    if target is None:
        return done("ok", grasp_q=q_g[: len(nan)])
    scene.attach(target, q_g)
    try:
        t0 = time.perf_counter()
        up = np.array([0.0, 0.0, 1.0]) * config.lift_height
        path, ep, er, col = ik.line(q_g, p_g + up, R_g, avoid=("table",),
                                    allow=(("carried", "table"),))  # fmt: skip
        clock("lift", t0)
        if col or not path or ep > config.cartesian_tolerance:
            why = ", ".join(f"{a}-{b}" for a, b, _ in col[:3]) or f"{1e3 * ep:.1f} mm short"
            return done("ik_failed", f"lift: {why}", q_g[: len(nan)])
        q_lift = path[-1]
        out.move("lift", np.concatenate([q_g[None], np.stack(path)]), 1.0, corners=False,
                 scale=config.carry_scale)  # fmt: skip

        t0 = time.perf_counter()
        drop = np.asarray(scene.robot.dropoff, np.float64)
        # Position only, seeded at the lift: the nearest arm solution keeps the wrist as it was
        # (holding the grasp's orientation there made long wrist swings that shook objects out).
        res = ik.solve(drop, R_g, q_lift, orientation=False)
        clock("dropoff", t0)
        if not res.converged:
            return done("unreachable" if not res.reachable else "ik_failed",
                        "no collision-free configuration at the drop-off with the object held",
                        q_g[: len(nan)])  # fmt: skip
        q_drop = res.q
        t0 = time.perf_counter()
        tr = plan_transit(scene, q_lift, q_drop, config)
        clock("transfer", t0)
        planners["transfer"] = tr.planner
        if not tr.solved:
            return done("no_path", f"transfer: {tr.reason}", q_g[: len(nan)])
        out.move("transfer", tr.path, 1.0, corners=True, scale=config.carry_scale)
        # Open in the first third, then wait: the return is planned with the hand open, and
        # half-open fingers hang lower than open ones.
        out.hold("release", q_drop, config.release_time, 1.0, -1.0, ramp=1.0 / 3.0)
    finally:
        scene.detach()

    # The released object is gone from the table: the return may pass where it stood. The hand
    # is open now (the release opened it), so the return is checked with open fingers.
    n = scene.robot.n_arm
    q_drop_open, q_home_open = (scene.full_q(q[:n], "open") for q in (q_drop, q0))
    t0 = time.perf_counter()
    tr = plan_transit(scene, q_drop_open, q_home_open, config, allow=(("robot", target),))
    clock("return", t0)
    planners["return"] = tr.planner
    if not tr.solved:
        return done("no_path", f"return: {tr.reason}", q_g[: len(nan)])
    out.move("return", tr.path, -1.0, corners=True)
    return done("ok", grasp_q=q_g[: len(nan)])


def plan_arm(
    scene: PlanningScene,
    grasp: GraspPose,
    *,
    start: Any = None,
    config: MotionConfig | None = None,
) -> ArmPlan:
    """Plans the whole pick of the scene's target for one grasp.

    Segments: ``transit`` (RRT-Connect from ``start`` to the IK solution of the pre-grasp pose),
    ``approach`` (straight TCP line to the grasp pose, mink differential IK, the hand may touch
    the target), ``close``, ``lift`` (``lift_height`` up, object attached), ``transfer``
    (RRT-Connect to the robot's drop-off with the object attached), ``release`` and ``return``
    (RRT-Connect back to ``start``). Without a target, the plan ends after ``close``.

    Args:
        scene: The :class:`PlanningScene` (its ``target`` is the object to pick).
        grasp: A :class:`GraspPose` (see :func:`grasp_poses`).
        start: Arm joint angles (n_arm,), radians; default the robot's home.
        config: :class:`MotionConfig`.

    Returns:
        An :class:`ArmPlan`; its ``status`` says whether and why not.

    Raises:
        StartInCollisionError: ``start`` collides (the message names the geoms).
        InvalidInputError: A NaN pose or configuration, or not a GraspPose.
    """
    return plan_arm_batch(scene, [grasp], start=start, config=config)[0]


def plan_arm_batch(
    scene: PlanningScene,
    grasps: Any,
    *,
    start: Any = None,
    config: MotionConfig | None = None,
    first_success: bool = False,
) -> list[ArmPlan]:
    """Plans picks for several grasps of the target, in order.

    Args:
        scene: The :class:`PlanningScene`.
        grasps: A list of :class:`GraspPose`, or a ``GraspPlan`` (its stable grasps, best
            first, see :func:`grasp_poses`).
        start: Arm joint angles (n_arm,); default home.
        config: :class:`MotionConfig`.
        first_success: Stop after the first ``ok`` plan (the grasp cycle).

    Returns:
        One :class:`ArmPlan` per grasp tried.
    """
    config = config_or_default(config, MotionConfig)
    if not isinstance(scene, PlanningScene):
        raise InvalidInputError(f"scene must be a PlanningScene, got {type(scene).__name__}")
    if not isinstance(grasps, (list, tuple)):
        grasps = grasp_poses(grasps)
    for g in grasps:
        if not isinstance(g, GraspPose):
            raise InvalidInputError(f"grasps must be GraspPose objects, got {type(g).__name__}")
        for what, (p, R) in (("pregrasp", g.pregrasp), ("grasp", g.grasp)):
            if not (np.all(np.isfinite(p)) and np.all(np.isfinite(R))):
                raise InvalidInputError(f"the {what} pose of candidate {g.index} has NaN or inf")
    scene.margin = config.check_margin
    scene.carried_margin = config.carried_margin
    scene.obstacle_margin = config.obstacle_margin
    ik = ArmIK(scene, config)
    plans = []
    for g in grasps:
        q0 = _check_start(scene, start, g.preshape)
        plans.append(_plan(scene, g, q0, config, ik))
        if first_success and plans[-1].ok:
            break
    return plans
