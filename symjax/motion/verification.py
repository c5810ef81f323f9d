"""Verification by replay: an :class:`ArmPlan` run open loop in C MuJoCo on the full robot scene.

The arm's position servos track the trajectory with a velocity feed-forward (the servo target is
``q + (kv / kp) dq``, which cancels the servo's damping lag) and gravity compensation on the
robot's bodies (a real arm controller compensates gravity); the hand's actuators go from the
pre-shape to the closing targets as the plan's closure command says, as in the grasp rollouts.
Objects are free bodies of convex hulls, so the target can be grasped, lifted and dropped.
"""

from __future__ import annotations

import copy
import dataclasses
from typing import Any

import mujoco
import numpy as np

from symjax.errors import InvalidInputError
from symjax.geometry import rotation_angle_np
from symjax.motion.arm_plan import ArmPlan
from symjax.motion.planning_scene import PlanningScene
from symjax.motion.scene_model import hull_list

__all__ = ["ReplayReport", "replay", "replay_model"]


@dataclasses.dataclass(frozen=True)
class ReplayReport:
    """What happened when a plan was executed in simulation.

    Attributes:
        max_tracking_error: Largest arm joint error over the motion, radians.
        tcp_error: TCP distance from the grasp pose once the arm has stopped there (0.2 s
            into the close), metres.
        tcp_rotation_error: TCP rotation from it, radians.
        collisions: Every robot contact with the table, floor, pedestal or a non-target object:
            ``(robot geom, other geom, first time s, deepest penetration m)``.
        object_contacts: Contacts of the held target with the table or other objects from the
            lift to the release: ``(target geom, other geom, first time s, penetration m)``.
        lifted: The target rose at least half the lift height during the lift.
        slip: Largest displacement of the target's centre of mass in the TCP frame from the
            start of the lift to the release, metres (NaN without a target); over a few
            centimetres the object left the hand.
        target_final: Final position of the target's centre of mass (3,), metres (NaN
            without a target).
        seconds: Wall time of the replay.
        snapshots: ``qpos`` of the replay model at the requested times.
        target_released: Position of the target's centre of mass when the release starts (3,),
            metres (NaN without a target or release).
        object_motion: Per object name, its rigid motion over the replay: the (4, 4) world
            transform from where it started to where it rests at the end (the next scene).
    """

    max_tracking_error: float
    tcp_error: float
    tcp_rotation_error: float
    collisions: tuple[tuple[str, str, float, float], ...]
    object_contacts: tuple[tuple[str, str, float, float], ...]
    lifted: bool
    slip: float
    target_final: np.ndarray
    seconds: float
    snapshots: tuple[np.ndarray, ...] = ()
    target_released: np.ndarray = dataclasses.field(default_factory=lambda: np.full(3, np.nan))
    object_motion: dict[str, np.ndarray] = dataclasses.field(default_factory=dict)

    @property
    def collision_free(self) -> bool:
        return not self.collisions


def replay_model(
    scene: PlanningScene, objects: dict[str, Any] | None = None, simulation: Any = None
) -> mujoco.MjModel:
    """The robot scene with gravity compensation and the objects as free bodies.

    The contacts are those of the grasp rollouts (:class:`symjax.grasp.SimulationConfig`: the
    friction impedance ratio, torsional friction on the hand, the objects' friction and
    density): with MuJoCo's default impedance ratio a held object crept out of the hand within
    seconds of carrying.

    Args:
        scene: The planning scene (robot and object poses).
        objects: ``{name: hulls}`` to simulate instead of the planning hulls (the true shapes
            when the plan was made on completed ones); same frames as the scene's objects.
        simulation: A :class:`symjax.grasp.SimulationConfig` (default settings when None).
    """
    from symjax.decompose.mjcf_object import object_spec
    from symjax.grasp.scene import contact_model
    from symjax.grasp.sim_config import SimulationConfig

    sim = simulation if simulation is not None else SimulationConfig()
    spec = scene.robot.spec()
    contact_model(spec, sim, scene.robot.hand_prefix)
    for b in spec.bodies:
        if b.name.startswith(("link", scene.robot.hand_prefix)):
            b.gravcomp = 1.0
    for name in scene.object_names:
        hulls = hull_list((objects or {}).get(name, scene._objects[name].hulls))
        p, R = scene.object_pose(name)
        world = [(v @ R.T + p, f) for v, f in hulls]
        # The free joint sits at the body origin: put it at the object's centre, not at the
        # world origin a metre away (a far joint made the contact solver launch the object).
        c = np.concatenate([v for v, _ in world]).mean(axis=0)
        object_spec([(v - c, f) for v, f in world], name=f"obj/{name}", pos=c, spec=spec,
                    mass=sim.object_mass, density=sim.object_density,
                    friction=sim.geom_friction)  # fmt: skip
    return spec.compile()


def _motion(m: mujoco.MjModel, d: mujoco.MjData, body: str) -> np.ndarray:
    """(4, 4) world transform of a free body from its model pose to its pose in ``d``."""
    b = m.body(body)
    T0, T1 = np.eye(4), np.eye(4)
    mat0 = np.zeros(9)
    mujoco.mju_quat2Mat(mat0, m.body_quat[b.id])
    T0[:3, :3], T0[:3, 3] = mat0.reshape(3, 3), m.body_pos[b.id]
    T1[:3, :3], T1[:3, 3] = d.xmat[b.id].reshape(3, 3), d.xpos[b.id]
    return T1 @ np.linalg.inv(T0)


def _feedforward(m: mujoco.MjModel, plan: ArmPlan, dq: np.ndarray, hand_q) -> np.ndarray:
    """Arm torques ``M(q) ddq + c(q, dq)`` of the planned motion (gravity is compensated), (N, n).

    Inverse dynamics without contacts, hand in its pre-shape, objects at rest.
    """
    n = plan.q.shape[1]
    ddq = np.gradient(dq, plan.t, axis=0) if len(plan.t) > 1 else np.zeros_like(dq)
    m2 = copy.copy(m)
    m2.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_CONSTRAINT
    d2 = mujoco.MjData(m2)
    mujoco.mj_resetDataKeyframe(m2, d2, m2.key("home").id)
    d2.qpos[n : n + len(hand_q)] = hand_q
    out = np.zeros_like(plan.q)
    for i in range(len(plan.t)):
        d2.qpos[:n], d2.qvel[:n], d2.qacc[:n] = plan.q[i], dq[i], ddq[i]
        mujoco.mj_inverse(m2, d2)
        out[i] = d2.qfrc_inverse[:n]
    return out


def replay(
    plan: ArmPlan,
    scene: PlanningScene,
    objects: dict[str, Any] | None = None,
    settle: float = 1.0,
    lift_height: float = 0.10,
    snapshots: tuple[float, ...] = (),
) -> ReplayReport:
    """Runs the plan in C MuJoCo and reports tracking, the TCP at the grasp and all contacts.

    Args:
        plan: An ``ok`` :class:`ArmPlan`.
        scene: The scene it was planned in.
        objects: Optional true hulls per object (see :func:`replay_model`).
        settle: Seconds simulated after the end of the plan.
        lift_height: The plan's lift, metres (``lifted`` needs half of it).
        snapshots: Times (seconds) at which to keep the full ``qpos`` (pictures).

    Raises:
        InvalidInputError: The plan is not ``ok``.
    """
    import time

    if not isinstance(plan, ArmPlan) or not plan.ok:
        raise InvalidInputError("replay needs an ArmPlan with status 'ok'")
    t_wall = time.perf_counter()
    m = replay_model(scene, objects)
    d = mujoco.MjData(m)
    robot, hand = scene.robot, scene.hand
    n = robot.n_arm
    pre = plan.grasp.preshape
    mujoco.mj_resetDataKeyframe(m, d, m.key("home").id)
    d.qpos[:n] = plan.q[0]
    d.qpos[n : n + hand.nq] = np.asarray(hand.preshape_qpos)[pre]
    mujoco.mj_forward(m, d)
    kp = m.actuator_gainprm[:n, 0]
    kv = -m.actuator_biasprm[:n, 2]
    c_pre = np.asarray(hand.preshape_ctrl, np.float64)[pre]
    c_open = np.asarray(hand.preshape_ctrl, np.float64)[hand.preshape_index("open")]
    c_closed = np.asarray(hand.closed_ctrl(pre), np.float64)
    dq = np.gradient(plan.q, plan.t, axis=0) if len(plan.t) > 1 else np.zeros_like(plan.q)
    # Servo target offset by the planned motion's torque over kp (computed-torque feed-forward):
    # without it the arm lags its trajectory by M ddq / kp, centimetres at the hand.
    ff = _feedforward(m, plan, dq, np.asarray(hand.preshape_qpos)[pre]) / kp
    gb = m.geom_bodyid
    names = [m.body(i).name for i in range(m.nbody)]
    robot_g = np.array([names[b].startswith(("link", robot.hand_prefix)) for b in gb])
    target = plan.target
    tgt_body = m.body(f"obj/{target}").id if target else -1
    tgt_g = gb == tgt_body
    env_g = ~robot_g & ~tgt_g
    tcp = m.site(robot.tcp_site).id
    times = plan.segment_times()
    # The arm has stopped at the grasp pose; the fingers have barely started to close.
    t_appr = times["close"][0] + min(0.2, 0.5 * (times["close"][1] - times["close"][0]))
    lift_t0, lift_t1 = times.get("lift", (np.inf, np.inf))
    release_t0 = times.get("release", (np.inf, np.inf))[0]
    z0 = lift_z = np.nan
    rel0, slip = None, 0.0 if target else np.nan
    released = None
    col: dict[tuple[int, int], list[float]] = {}
    ocol: dict[tuple[int, int], list[float]] = {}
    max_err, tcp_err, rot_err = 0.0, np.nan, np.nan
    t_end = plan.duration + settle
    steps = int(np.ceil(t_end / m.opt.timestep))
    shots, pending = [], sorted(snapshots)
    for _ in range(steps):
        t = d.time
        i = min(int(np.searchsorted(plan.t, t)), len(plan.t) - 1)
        d.ctrl[:n] = plan.q[i] + (kv / kp) * dq[i] + ff[i]
        h = plan.hand[i]
        d.ctrl[n:] = c_pre + h * (c_closed - c_pre) if h >= 0 else c_pre - h * (c_open - c_pre)
        mujoco.mj_step(m, d)
        while pending and d.time >= pending[0]:
            shots.append(d.qpos.copy())
            pending.pop(0)
        max_err = max(max_err, float(np.abs(d.qpos[:n] - plan.q[i]).max()))
        if np.isnan(tcp_err) and d.time >= t_appr:
            p_g, R_g = plan.grasp.grasp
            tcp_err = float(np.linalg.norm(d.site_xpos[tcp] - p_g))
            rot_err = rotation_angle_np(d.site_xmat[tcp].reshape(3, 3), R_g)
        if tgt_body >= 0:
            if np.isnan(z0) and d.time >= lift_t0:
                z0 = float(d.xipos[tgt_body][2])
            if np.isnan(lift_z) and d.time >= lift_t1:
                lift_z = float(d.xipos[tgt_body][2])
            if released is None and d.time >= release_t0:
                released = d.xipos[tgt_body].copy()
            if lift_t0 <= d.time < release_t0:
                Rt = d.site_xmat[tcp].reshape(3, 3)
                rel = Rt.T @ (d.xipos[tgt_body] - d.site_xpos[tcp])
                rel0 = rel if rel0 is None else rel0
                slip = max(slip, float(np.linalg.norm(rel - rel0)))
        for c in d.contact[: d.ncon]:
            a, b = int(c.geom1), int(c.geom2)
            if c.dist >= 0:
                continue
            if (robot_g[a] and env_g[b]) or (robot_g[b] and env_g[a]):
                key, store = ((a, b) if robot_g[a] else (b, a)), col
            elif lift_t0 <= d.time < release_t0 and (
                (tgt_g[a] and env_g[b]) or (tgt_g[b] and env_g[a])
            ):
                if d.time < lift_t0 + 0.2:  # still leaving the table
                    continue
                key, store = ((a, b) if tgt_g[a] else (b, a)), ocol
            else:
                continue
            rec = store.setdefault(key, [d.time, 0.0])
            rec[1] = max(rec[1], -float(c.dist))
    lifted = bool(tgt_body >= 0 and lift_z - z0 > 0.5 * lift_height)

    def listing(store):
        items = sorted(store.items(), key=lambda kv: kv[1][0])
        return tuple((m.geom(a).name, m.geom(b).name, round(t, 3), v) for (a, b), (t, v) in items)

    return ReplayReport(
        target_released=released if released is not None else np.full(3, np.nan),
        object_motion={name: _motion(m, d, f"obj/{name}") for name in scene.object_names},
        max_tracking_error=max_err,
        tcp_error=tcp_err,
        tcp_rotation_error=rot_err,
        collisions=listing(col),
        object_contacts=listing(ocol),
        lifted=lifted,
        slip=slip,
        target_final=d.xipos[tgt_body].copy() if tgt_body >= 0 else np.full(3, np.nan),
        seconds=time.perf_counter() - t_wall,
        snapshots=tuple(shots),
    )
