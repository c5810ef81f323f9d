"""Inverse kinematics with mink: TCP poses from restarts, and straight-line TCP motions.

A :class:`FrameTask` pulls the TCP site to its target, a :class:`PostureTask` keeps the arm
near home (elbow up), a :class:`DofFreezingTask` holds the hand's joints in their pre-shape,
:class:`ConfigurationLimit` keeps the joints in range and :class:`CollisionAvoidanceLimit`
keeps the arm, the hand and a held object ``clearance`` away from the table and the obstacles.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from symjax.geometry import rotation_angle_np
from symjax.motion.config import MotionConfig
from symjax.motion.planning_scene import PlanningScene, SceneModel

__all__ = ["ArmIK", "IKResult"]


@dataclasses.dataclass(frozen=True)
class IKResult:
    """Outcome of one IK query.

    Attributes:
        q: The last configuration, full qpos (nq,); valid only when ``converged``.
        converged: Within the position and orientation tolerances and collision-free.
        position_error: Remaining TCP distance to the target, metres.
        orientation_error: Remaining TCP rotation, radians.
        iterations: IK steps over all seeds.
        seeds: Seeds tried.
        reachable: Some seed reached the pose within tolerance (maybe in collision).
        collisions: Contacts of the best reaching solution, when it collides.
    """

    q: np.ndarray
    converged: bool
    position_error: float
    orientation_error: float
    iterations: int
    seeds: int
    reachable: bool
    collisions: tuple[tuple[str, str, float], ...] = ()


class ArmIK:
    """mink IK for one :class:`PlanningScene` (solvers cached per compiled variant).

    Args:
        scene: The planning scene.
        config: :class:`MotionConfig`.
    """

    def __init__(self, scene: PlanningScene, config: MotionConfig):
        self.scene = scene
        self.config = config
        self._solvers: dict = {}
        self._rng = np.random.default_rng(config.seed)

    def _solver(self, sm: SceneModel, avoid: tuple[str, ...], table: float | None = None):
        key = (id(sm), avoid, table, self.scene.target)
        if key in self._solvers:
            return self._solvers[key]
        import mink

        m, cfg = sm.model, self.config
        n = self.scene.robot.n_arm
        conf = mink.Configuration(m)
        frame = mink.FrameTask(self.scene.robot.tcp_site, "site", position_cost=1.0,
                               orientation_cost=1.0, lm_damping=cfg.ik_damping)  # fmt: skip
        posture = mink.PostureTask(m, cost=cfg.posture_cost)
        posture.set_target(self.scene.full_q(self.scene.robot.home))
        freeze = mink.DofFreezingTask(m, dof_indices=list(range(n, m.nv)))
        env = [int(g) for g in sm.fixed_geoms if m.geom(int(g)).name != "floor"]
        table_geom = int(sm.fixed_geoms[0])
        # The objects other than the target keep the wider obstacle margin (own limit below).
        wide = cfg.obstacle_margin > cfg.clearance
        others: list[int] = []
        for name, gs in sm.object_geoms.items():
            if name in avoid:
                continue
            if wide and name != self.scene.target:
                others += [int(g) for g in gs]
            else:
                env += [int(g) for g in gs]
        robot = [int(g) for g in np.concatenate([sm.arm_geoms, sm.hand_geoms])]
        carried = [int(g) for g in sm.carried_geoms]
        pairs = [(robot, env)] if env else []
        if carried:
            # Lifting off the table: the held object starts on it (``avoid`` has "table").
            env_c = [g for g in env + others if not ("table" in avoid and g == table_geom)]
            if env_c:
                pairs.append((carried, env_c))
        # Self-collision: the hand (and what it holds) against the arm links the MJCF does not
        # exclude (mink does not read the model's <exclude> list).
        excluded = {(int(s) >> 16, int(s) & 0xFFFF) for s in m.exclude_signature}
        gb = m.geom_bodyid
        for g in np.concatenate([sm.hand_geoms, sm.carried_geoms]):
            arm = [
                int(a) for a in sm.arm_geoms
                if (gb[a], gb[g]) not in excluded and (gb[g], gb[a]) not in excluded
            ]  # fmt: skip
            if arm:
                pairs.append(([int(g)], arm))
        limits = [mink.ConfigurationLimit(m)]
        if table is not None and env:
            # The table keeps its own clearance (the approach's): robot-table is its own limit.
            pairs = [(robot, [g for g in env if g != table_geom]), *pairs[1:]]
            if table > 0:
                limits.append(mink.CollisionAvoidanceLimit(
                    m, [(robot, [table_geom])], minimum_distance_from_collisions=table,
                    collision_detection_distance=cfg.detection_distance,
                ))  # fmt: skip
        pairs = [pr for pr in pairs if pr[0] and pr[1]]
        if pairs and cfg.clearance > 0:
            limits.append(mink.CollisionAvoidanceLimit(
                m, pairs, minimum_distance_from_collisions=cfg.clearance,
                collision_detection_distance=cfg.detection_distance,
            ))  # fmt: skip
        if others:
            limits.append(mink.CollisionAvoidanceLimit(
                m, [(robot, others)], minimum_distance_from_collisions=cfg.obstacle_margin,
                collision_detection_distance=max(cfg.detection_distance,
                                                 2 * cfg.obstacle_margin),
            ))  # fmt: skip
        out = (conf, frame, posture, freeze, limits)
        self._solvers[key] = out
        return out

    def _steps(self, sm, solver, q0, p, R, iterations, use_collision, tol_p, tol_r):
        """Runs differential IK from ``q0``; returns (q, pos error, rot error, steps)."""
        import mink

        conf, frame, posture, freeze, limits = solver
        cfg = self.config
        self.scene.sync(sm, conf.data)
        conf.update(q0)
        frame.set_target(mink.SE3.from_rotation_and_translation(mink.SO3.from_matrix(R), p))
        lim = limits if use_collision else limits[:1]
        site = sm.tcp_site
        d = conf.data
        ep = er = np.inf
        best = np.inf
        stall = 0
        for it in range(iterations):
            try:
                v = mink.solve_ik(conf, [frame, posture], cfg.ik_dt, "daqp", cfg.ik_damping,
                                  limits=lim, constraints=[freeze])  # fmt: skip
            except mink.NoSolutionFound:
                break
            conf.integrate_inplace(v, cfg.ik_dt)
            ep = float(np.linalg.norm(p - d.site_xpos[site]))
            er = rotation_angle_np(R, d.site_xmat[site].reshape(3, 3))
            if ep < tol_p and er < tol_r:
                return conf.q.copy(), ep, er, it + 1
            # A local minimum (a joint limit, an obstacle): stop early and let a restart try.
            score = ep + 0.1 * er
            stall = stall + 1 if score > best - 1e-5 else 0
            best = min(best, score)
            if stall >= 10:
                break
        return conf.q.copy(), ep, er, it + 1

    def seeds(self, q_start: np.ndarray) -> list[np.ndarray]:
        """Start, home, then random arm configurations (hand joints as in ``q_start``)."""
        robot = self.scene.robot
        n = robot.n_arm
        home = q_start.copy()
        home[:n] = robot.home
        out = [q_start.copy(), home]
        sm = self.scene.scene_model()
        lo, hi = sm.model.jnt_range[:n, 0], sm.model.jnt_range[:n, 1]
        for _ in range(self.config.ik_restarts):
            q = q_start.copy()
            # Random seeds near home (a quarter of each range) find the elbow-up branch.
            q[:n] = np.clip(robot.home + 0.25 * (hi - lo) * self._rng.uniform(-1, 1, n), lo, hi)
            out.append(q)
        return out

    def solve(
        self,
        p: np.ndarray,
        R: np.ndarray,
        q_start: np.ndarray,
        avoid: tuple[str, ...] = (),
        allow: tuple[tuple[str, str], ...] = (),
        orientation: bool = True,
    ) -> IKResult:
        """A collision-free configuration with the TCP at ``(p, R)``.

        Each seed is first solved without the collision limit (pure kinematics, fast); a
        solution that collides is re-solved from there with the collision-avoidance limit.

        Args:
            p: TCP target position (3,), metres, world frame.
            R: TCP target rotation (3, 3).
            q_start: Full configuration (nq,): the first seed; its hand joints are kept.
            avoid: Objects the collision limit ignores (the target on the approach); with
                ``"table"``, a held object may touch the table (the lift).
            allow: Allowed contacts of the final check (see :meth:`PlanningScene.collisions`).
            orientation: False: position only (the drop-off).
        """
        cfg = self.config
        sm = self.scene.scene_model()
        solver = self._solver(sm, avoid)
        solver[1].set_orientation_cost(1.0 if orientation else 0.0)
        tol_r = cfg.orientation_tolerance if orientation else np.inf
        total, best, reach_q, reach_col = 0, (np.inf, np.inf, q_start), None, ()
        seeds = self.seeds(np.asarray(q_start, np.float64))
        for k, q0 in enumerate(seeds):
            q, ep, er, it = self._steps(sm, solver, q0, p, R, cfg.ik_iterations, False,
                                        cfg.position_tolerance, tol_r)  # fmt: skip
            total += it
            if ep + er < best[0] + best[1]:
                best = (ep, er, q)
            if not (ep < cfg.position_tolerance and er < tol_r):
                continue
            col = self.scene.collisions(q, allow)
            if not col:
                return IKResult(q, True, ep, er, total, k + 1, True)
            reach_q, reach_col = q, tuple(col)
            q2, ep2, er2, it2 = self._steps(sm, solver, q, p, R, cfg.ik_iterations, True,
                                            cfg.position_tolerance, tol_r)  # fmt: skip
            total += it2
            if ep2 < cfg.position_tolerance and er2 < tol_r and self.scene.is_valid(q2, allow):
                return IKResult(q2, True, ep2, er2, total, k + 1, True)
        if reach_q is not None:
            return IKResult(reach_q, False, 0.0, 0.0, total, len(seeds), True, reach_col)
        return IKResult(best[2], False, best[0], best[1], total, len(seeds), False)

    def line(
        self,
        q_start: np.ndarray,
        goal_p: np.ndarray,
        goal_R: np.ndarray,
        avoid: tuple[str, ...] = (),
        allow: tuple[tuple[str, str], ...] = (),
        table: float | None = None,
    ) -> tuple[list[np.ndarray], float, float, tuple]:
        """Tracks the straight TCP line from ``q_start``'s TCP to ``(goal_p, goal_R)``.

        ``table`` (metres) replaces the config's clearance from the table for this line.

        Returns:
            ``(configurations, position error at the goal, orientation error, contacts)``:
            one configuration per waypoint (``cartesian_step`` apart), the last one iterated to
            convergence; contacts of the first waypoint in collision, if any: the motion stops
            at the waypoint before it and the errors are measured there.
        """
        cfg = self.config
        sm = self.scene.scene_model()
        solver = self._solver(sm, avoid, table)
        solver[1].set_orientation_cost(1.0)
        p0, _ = self.scene.tcp_pose(q_start)
        n = max(1, int(np.ceil(np.linalg.norm(goal_p - p0) / cfg.cartesian_step)))
        path, q = [], np.asarray(q_start, np.float64)
        ep = er = np.inf
        for i in range(1, n + 1):
            p = p0 + (goal_p - p0) * (i / n)
            iters = cfg.ik_iterations if i == n else cfg.cartesian_iterations
            q, ep, er, _ = self._steps(
                sm, solver, q, p, goal_R, iters, True, cfg.position_tolerance,
                cfg.orientation_tolerance,
            )  # fmt: skip
            col = self.scene.collisions(q, allow)
            if col:
                # Stop at the last waypoint that keeps the margin (errors measured there), after
                # a few shorter steps towards the contact: a waypoint spacing short of it.
                if not path:
                    return path, np.inf, np.inf, tuple(col)
                p_prev = p0 + (goal_p - p0) * ((i - 1) / n)
                for f in (0.75, 0.5, 0.25):
                    qf, *_ = self._steps(sm, solver, path[-1], p_prev + f * (p - p_prev), goal_R,
                                         cfg.cartesian_iterations, True, cfg.position_tolerance,
                                         cfg.orientation_tolerance)  # fmt: skip
                    if not self.scene.collisions(qf, allow):
                        path.append(qf)
                        break
                return path, *tcp_error(self.scene, path[-1], goal_p, goal_R), tuple(col)
            path.append(q)
        return path, ep, er, ()


def tcp_error(scene: PlanningScene, q: np.ndarray, p: np.ndarray, R: np.ndarray):
    """``(distance m, angle rad)`` of the TCP at ``q`` from ``(p, R)``."""
    pc, Rc = scene.tcp_pose(q)
    return float(np.linalg.norm(pc - p)), rotation_angle_np(Rc, R)
