"""Collision-free joint-space transit with OMPL's RRT-Connect.

The state space is the arm's joint box; a state is valid when the planning scene reports no
contact closer than its margin. Motions are checked every ``MotionConfig.resolution`` radians.
The direct joint-space line is tried first: when it is free, no tree is grown (the common case
above a sparse table). Solutions are shortcut by OMPL's simplifier and checked again densely.
"""

from __future__ import annotations

import dataclasses
import time

import numpy as np

from symjax.motion.config import MotionConfig
from symjax.motion.planning_scene import PlanningScene

__all__ = ["TransitResult", "levers", "plan_transit", "segment_valid"]


@dataclasses.dataclass(frozen=True)
class TransitResult:
    """A joint-space path, or why none was found.

    Attributes:
        path: Waypoints, full qpos, shape (K, nq) (start and goal included); empty on failure.
        solved: Whether a collision-free path was found.
        planner: ``"direct"`` (the straight line was free) or ``"rrt_connect"``.
        seconds: Planning time, simplification included.
        reason: Why not, when not solved.
    """

    path: np.ndarray
    solved: bool
    planner: str
    seconds: float
    reason: str = ""


def levers(scene: PlanningScene) -> np.ndarray:
    """Per arm joint, an upper bound of how far a robot point can be from its axis, metres (n,).

    The longest chain of link offsets below the joint's body plus that link's farthest geom: a
    joint step ``dq`` moves no robot point more than ``lever * |dq|``.
    """
    m = scene.scene_model().model
    reach = np.zeros(m.nbody)
    for g in range(m.ngeom):
        b = int(m.geom_bodyid[g])
        reach[b] = max(reach[b], float(np.linalg.norm(m.geom_pos[g]) + m.geom_rbound[g]))
    for b in range(m.nbody - 1, 0, -1):  # children come after their parents
        p = int(m.body_parentid[b])
        if p > 0:
            reach[p] = max(reach[p], float(np.linalg.norm(m.body_pos[b])) + reach[b])
    return np.array([reach[int(m.jnt_bodyid[i])] for i in range(scene.robot.n_arm)])


def segment_valid(scene: PlanningScene, a: np.ndarray, b: np.ndarray, step: float,
                  allow: tuple = (), lever: np.ndarray | None = None) -> bool:  # fmt: skip
    """Whether the joint-space line from ``a`` to ``b`` is collision-free, checked so densely
    that no robot point moves more than ``step`` metres between two checks (by :func:`levers`).
    """
    n = scene.robot.n_arm
    lever = levers(scene) if lever is None else lever
    reach = float(np.abs(b[:n] - a[:n]) @ lever)
    steps = max(1, int(np.ceil(reach / step)))
    for t in np.linspace(0.0, 1.0, steps + 1)[1:]:
        if not scene.is_valid(a + t * (b - a), allow):
            return False
    return True


def _ompl():
    from ompl import base as ob
    from ompl import geometric as og
    from ompl import util as ou

    # Every query starts from the same seed, so a plan depends on its own inputs only: a scene
    # rerun alone repeats what it did in a batch. OMPL warns that a reseed after the first
    # sample is not deterministic; it is (a fresh process gives the same paths), so the warning
    # is silenced for the call.
    ou.setLogLevel(ou.LogLevel.LOG_NONE)
    ou.RNG.setSeed(1)
    ou.setLogLevel(ou.LogLevel.LOG_ERROR)
    return ob, og


def plan_transit(
    scene: PlanningScene,
    start: np.ndarray,
    goal: np.ndarray,
    config: MotionConfig,
    allow: tuple = (),
    direct_first: bool = True,
) -> TransitResult:
    """Plans a collision-free arm motion between two full configurations.

    The hand joints stay as in ``start``; only the arm moves.

    Args:
        scene: The planning scene (its attached object moves with the hand).
        start, goal: Full configurations (nq,), collision-free.
        config: :class:`MotionConfig` (time limit, range, resolution, simplification).
        allow: Allowed contacts (see :meth:`PlanningScene.collisions`).
        direct_first: Try the straight joint-space line before growing trees.
    """
    t0 = time.perf_counter()
    start = np.asarray(start, np.float64)
    goal = np.asarray(goal, np.float64)
    for name, q in (("start", start), ("goal", goal)):
        if not scene.is_valid(q, allow):
            col = scene.collisions(q, allow)[:3]
            why = f"the {name} is in collision: {col}"
            return TransitResult(np.zeros((0, len(start))), False, "none",
                                 time.perf_counter() - t0, why)  # fmt: skip
    lever = levers(scene)
    if direct_first and segment_valid(scene, start, goal, config.check_step, allow, lever):
        return TransitResult(np.stack([start, goal]), True, "direct", time.perf_counter() - t0)
    ob, og = _ompl()
    n = scene.robot.n_arm
    m = scene.scene_model().model
    lo, hi = m.jnt_range[:n, 0], m.jnt_range[:n, 1]
    space = ob.RealVectorStateSpace(n)
    bounds = ob.RealVectorBounds(n)
    for i in range(n):
        bounds.setLow(i, float(lo[i]))
        bounds.setHigh(i, float(hi[i]))
    space.setBounds(bounds)
    ss = og.SimpleSetup(space)
    q = start.copy()

    def valid(state) -> bool:
        for i in range(n):
            q[i] = state[i]
        return bool(scene.is_valid(q, allow))  # OMPL needs a Python bool, not numpy's

    ss.setStateValidityChecker(valid)
    si = ss.getSpaceInformation()
    # Half the dense re-check's step, so that OMPL's own motion checks rarely pass a path the
    # re-check rejects.
    si.setStateValidityCheckingResolution(0.5 * config.resolution / space.getMaximumExtent())
    s, g = space.allocState(), space.allocState()
    for i in range(n):
        s[i], g[i] = float(start[i]), float(goal[i])
    ss.setStartAndGoalStates(s, g)
    planner = og.RRTConnect(si)
    planner.setRange(config.planner_range)
    ss.setPlanner(planner)
    reason = f"RRT-Connect found no path in {config.planner_time} s"
    for _attempt in range(3):
        ss.clear()
        solved = ss.solve(config.planner_time)
        if not (bool(solved) and ss.haveExactSolutionPath()):
            break
        if config.simplify_time > 0:
            # Iteration-bounded, not time-bounded: a time limit gave other paths on a loaded CPU
            # and made runs of the same plan differ.
            ss.getPathSimplifier().simplifyMax(ss.getSolutionPath())
        states = ss.getSolutionPath().getStates()
        path = np.repeat(start[None], len(states), axis=0)
        for k, st in enumerate(states):
            path[k, :n] = [st[i] for i in range(n)]
        path[0], path[-1] = start, goal
        # OMPL checks motions at its own resolution; re-check densely before trusting it.
        if all(segment_valid(scene, a, b, config.check_step, allow, lever)
               for a, b in zip(path[:-1], path[1:], strict=True)):  # fmt: skip
            return TransitResult(path, True, "rrt_connect", time.perf_counter() - t0)
        reason = "every path found collides between waypoints when re-checked densely"
    return TransitResult(np.zeros((0, len(start))), False, "rrt_connect",
                         time.perf_counter() - t0, reason)  # fmt: skip
