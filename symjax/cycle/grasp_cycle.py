"""The paper's grasp cycle (Algorithm 1) on a table: perceive, predict every object's shape,
decompose it, plan grasps on it with the other objects present, plan the arm for the stable
grasps in ranked order, execute the first that plans on the true objects, perceive again.

A round executes at most one pick; the next round sees the table as the pick left it (the
objects may have been pushed), so every shape is predicted again from the new frame.
"""

from __future__ import annotations

import time
from collections import Counter
from typing import Any

import numpy as np

from symjax.cycle.config import CycleConfig
from symjax.cycle.report import CycleReport, ObjectOutcome, Round
from symjax.cycle.shapes import decompose_shapes, predict_shapes
from symjax.errors import InvalidInputError, SymjaxError, config_or_default, one_line

__all__ = ["GENERATORS", "clear_table"]

#: Each robot's own candidate generator (paper Section IV-A).
GENERATORS = {"kth": "kth", "uji": "uji"}


def _frame(world: Any, data: Any) -> tuple[Any, Any]:
    """(depth, camera) of the current frame."""
    if world is not None:
        return world.scene.depth, world.scene.camera
    return data.depth, data.camera


def _plan_object(i, meshes, decs, ts, robot, hand, cfg, names, shapes=None) -> tuple[dict, Any]:
    """GetGraspCandidates, PlanGrasp and PlanArmTrajectory for hypothesis ``i``; with
    ``shapes`` (mode ``K``) the grasps are ranked across them (the others decomposed here).

    Returns the try's record and the first ``ok`` arm plan (or None); stage times are added
    to the record under ``"seconds"``.
    """
    from symjax import grasp, motion

    rec: dict[str, Any] = {"hypothesis": i, "stage": "", "reason": "", "candidates": 0,
                           "stable": 0, "arm_tried": 0, "seconds": {}}  # fmt: skip
    for stage, item in (("PredictObjectShape", meshes[i]), ("ConvexDecomposition", decs[i])):
        if isinstance(item, SymjaxError):
            rec.update(stage=stage, reason=one_line(item, 240))
            return rec, None
    others = [d for j, d in enumerate(decs) if j != i and not isinstance(d, SymjaxError)]
    try:
        hulls = decs[i]
        if shapes is not None:
            from symjax.decompose import decompose

            hulls = [hulls] + [decompose(m, cfg.decompose) for m in shapes.meshes[1:]]
        gp = grasp.plan(meshes[i], hand, GENERATORS[robot.name], hulls=hulls, table=ts.table,
                        obstacles=others, candidates=cfg.candidates, simulation=cfg.simulation,
                        execution=cfg.execution, backend=cfg.backend, shapes=shapes,
                        robustness=cfg.robustness)  # fmt: skip
    except SymjaxError as e:
        rec.update(stage="GetGraspCandidates", reason=one_line(e, 240))
        return rec, None
    sims = ("scene", "simulate", "shapes", "robustness")
    rec["seconds"] = {"GetGraspCandidates": gp.seconds["candidates"],
                      "PlanGrasp": sum(gp.seconds.get(k, 0.0) for k in sims)}  # fmt: skip
    rec["candidates"] = len(gp)
    o = gp.outcomes.numpy()
    rec["stable"] = int(np.sum(o.success))
    # A rollout may close the fingers against the table; the arm is never let near it, so those
    # grasps cannot be executed without a collision.
    touching = set(np.asarray(gp.order)[np.asarray(o.table_contact, bool)].tolist())
    stable = motion.grasp_poses(gp)
    poses = _distinct([g for g in stable if g.index not in touching])[: cfg.arm_grasps or None]
    rec["stable_off_table"] = len(poses)
    if not poses:
        why = (f"no stable grasp among {len(gp)} candidates" if not stable else
               f"each of the {len(stable)} stable grasps has the fingers on the table")  # fmt: skip
        rec.update(stage="PlanGrasp", reason=why)
        return rec, None
    t0 = time.perf_counter()
    scene = motion.PlanningScene(
        robot,
        {n: d.hulls for n, d in zip(names, decs, strict=True) if not isinstance(d, SymjaxError)},
        target=names[i],
    )
    try:
        plans = motion.plan_arm_batch(scene, poses, config=cfg.motion, first_success=True)
    except SymjaxError as e:
        plans, rec["reason"] = [], one_line(e, 240)
    rec["seconds"]["PlanArmTrajectory"] = time.perf_counter() - t0
    rec["arm_tried"] = len(plans)
    ok = next((p for p in plans if p.ok), None)
    if ok is None:
        statuses = Counter(p.status for p in plans)
        rec["arm_reasons"] = sorted({p.reason[:160] for p in plans})[:5]
        rec.update(stage="PlanArmTrajectory",
                   reason=rec["reason"] or f"no arm plan for {len(poses)} distinct stable grasps: "
                   + ", ".join(f"{k} {v}" for k, v in sorted(statuses.items())))  # fmt: skip
    return rec, ok


def clear_table(
    scene_or_frame: Any, robot: Any, config: CycleConfig | None = None, *, pictures: bool = False
) -> CycleReport:
    """Runs the grasp cycle until the table is clear or nothing plans.

    Args:
        scene_or_frame: A :class:`symjax.datasets.ScanScene` (simulated: each pick is executed
            on its true objects and the table seen again) or a :class:`symjax.io.DepthFrame`
            (a real frame: one round planned, nothing executed; modes C and P only).
        robot: ``"kth"``, ``"uji"`` or a :class:`symjax.robots.Robot`; a scene's own robot.
        config: :class:`CycleConfig` (mode C by default).
        pictures: Keep what the report's pictures need (the first frame and its hypotheses;
            per executed pick the shapes, the plan, its replay with key frames and the true
            scene it ran in) in ``report.extras``.

    Returns:
        A :class:`CycleReport`.

    Raises:
        InvalidInputError: Not a scene or frame, a robot that is not the scene's, mode T
            without a simulated scene.
        UnknownNameError: An unknown robot.
    """
    from symjax import hands, perception, robots
    from symjax.datasets.scan_scenes import ScanScene
    from symjax.io.depth_frame import DepthFrame

    cfg = config_or_default(config, CycleConfig)
    r = robot if isinstance(robot, robots.Robot) else robots.load(str(robot))
    if isinstance(scene_or_frame, ScanScene):
        if scene_or_frame.robot != r.name:
            raise InvalidInputError(
                f"the scene was drawn for robot {scene_or_frame.robot!r}, not {r.name!r}"
            )
        from symjax.cycle.world import SimWorld

        world = SimWorld(scene_or_frame, r, cfg)
    elif isinstance(scene_or_frame, DepthFrame):
        if cfg.mode == "T":
            raise InvalidInputError("mode T (true meshes) needs a simulated ScanScene, not a frame")
        world = None
    else:
        raise InvalidInputError(
            "clear_table takes a symjax.datasets.ScanScene or a symjax.io.DepthFrame, got"
            f" {type(scene_or_frame).__name__}"
        )
    hand = hands.load(r.hand)
    t_start = time.perf_counter()
    outcome: dict[str, dict[str, Any]] = {}
    if world is not None:
        outcome = {n: {"cleared": False, "attempts": 0, "stage": "", "reason": ""}
                   for n in world.names}  # fmt: skip
    rounds: list[Round] = []
    warnings: tuple[str, ...] = ()
    extras: dict[str, Any] = {"rounds": []}
    stop = "nothing plans"
    max_rounds = 1 if world is None else cfg.attempts_per_object * len(world.names) + 1
    for index in range(max_rounds):
        sec: dict[str, float] = {}
        t0 = time.perf_counter()
        depth, camera = _frame(world, scene_or_frame)
        ts = perception.segment(depth, camera, cfg.segmentation)
        sec["GetObjectHypotheses"] = time.perf_counter() - t0
        seen: set[str] = set()  # the objects a hypothesis of this frame stands for
        if index == 0:
            warnings = ts.warnings
            extras["first"] = {"depth": depth, "segmentation": ts}
        if ts.empty:
            stop = "table clear"
            rounds.append(Round(index, 0, sec, ()))
            break
        k = len(ts.objects)
        match = world.match(ts.labels, k) if world is not None else [-1] * k
        if world is not None:
            seen = {world.names[world.alive[j]] for j in match if j >= 0}
        names = [f"h{i}" for i in range(k)]
        t0 = time.perf_counter()
        truth_m = truth_d = None
        if cfg.mode == "T":
            truth_m = [world.true_mesh(j) if j >= 0 else None for j in match]
            truth_d = [world.true_hulls(j) if j >= 0 else None for j in match]
        meshes = predict_shapes(ts, cfg, truth_m)
        sets = meshes if cfg.mode == "K" else None
        if sets is not None:  # the first shape stands for the object everywhere but PlanGrasp
            meshes = [s if isinstance(s, SymjaxError) else s.meshes[0] for s in sets]
        sec["PredictObjectShape"] = time.perf_counter() - t0
        t0 = time.perf_counter()
        decs = decompose_shapes(meshes, cfg, truth_d)
        sec["ConvexDecomposition"] = time.perf_counter() - t0
        tried, chosen = [], None
        for i in range(k):
            obj = world.names[world.alive[match[i]]] if match[i] >= 0 else None
            if obj is not None and outcome[obj]["attempts"] >= cfg.attempts_per_object:
                continue
            rec, plan = _plan_object(i, meshes, decs, ts, r, hand, cfg, names,
                                     None if sets is None else sets[i])  # fmt: skip
            rec["object"] = obj
            for s, v in rec.pop("seconds").items():
                sec[s] = sec.get(s, 0.0) + v
            tried.append(rec)
            if obj is not None and rec["stage"]:
                outcome[obj].update(stage=rec["stage"], reason=rec["reason"])
            if plan is not None and (world is None or match[i] >= 0):
                chosen = (i, plan, obj)
                break
        if chosen is None:
            stop = "nothing plans" if tried else "attempts exhausted"
            rounds.append(Round(index, k, sec, tuple(tried)))
            break
        i, plan, obj = chosen
        if world is None:
            stop = "frame only"
            rounds.append(Round(index, k, sec, tuple(tried), i, None, None, plan.summary()))
            break
        t0 = time.perf_counter()
        shots = _key_times(plan) if pictures else ()
        result, rep = world.execute(plan, match[i], snapshots=shots)
        sec["ExecuteGrasp"] = time.perf_counter() - t0
        o = outcome[obj]
        o["attempts"] += 1
        if result["delivered"]:
            o.update(cleared=True, stage="", reason="")
        else:
            o.update(stage="ExecuteGrasp", reason="not at the drop-off after the pick ("
                     + ("lifted, dropped in transit" if result["lifted"] else "not lifted")
                     + f", slip {result['slip_mm']} mm)")  # fmt: skip
        for n in result["knocked_off"]:
            outcome[n].update(
                stage="ExecuteGrasp", reason=f"knocked off the table by the pick of {obj}"
            )
        rounds.append(Round(index, k, sec, tuple(tried), i, obj, result, plan.summary()))
        if pictures:
            extras["rounds"].append({"meshes": meshes, "plan": plan, "replay": rep,
                                     "truth": world.last_truth})  # fmt: skip
    else:
        stop = "attempts exhausted"
    if world is not None and not world.alive and stop != "table clear":
        stop = "table clear"
    if world is not None:
        for n, o in outcome.items():
            if not o["cleared"] and not o["stage"]:
                o["stage"], o["reason"] = untried_outcome(n in seen, stop)
        objects = tuple(
            ObjectOutcome(n, o["cleared"], o["attempts"], o["stage"], o["reason"])
            for n, o in outcome.items()
        )
    else:
        objects = tuple(ObjectOutcome(f"hypothesis{t['hypothesis']}", False, 0,
                                      t["stage"] or "ExecuteGrasp",
                                      t["reason"] or "a real frame: planned, not executed")
                        for t in (rounds[-1].tried if rounds else ()))  # fmt: skip
    return CycleReport(r.name, cfg.mode, objects, tuple(rounds), stop,
                       time.perf_counter() - t_start, tuple(warnings),
                       extras if pictures else {})  # fmt: skip


def untried_outcome(seen: bool, stop: str) -> tuple[str, str]:
    """``(stage, reason)`` of an object that was never tried: unseen in the last frame, or seen
    but not reached before the cycle stopped (``stop``, the report's stop reason)."""
    if not seen:
        return ("GetObjectHypotheses", "not found as an object of its own in the last frame"
                " (hidden behind another object or merged with one)")  # fmt: skip
    return "PlanGrasp", f"not tried before the cycle stopped ({stop})"


def _distinct(poses: list) -> list:
    """Grasp poses without repeats (best first): candidates that differ only in their start
    distance reach the same grasp pose, and the arm would be planned for it again."""
    out: list = []
    for g in poses:
        p, R = g.grasp
        if not any(np.linalg.norm(p - q.grasp[0]) < 0.005 and np.abs(R - q.grasp[1]).max() < 0.05
                   for q in out):  # fmt: skip
            out.append(g)
    return out


def _key_times(plan: Any) -> tuple[float, ...]:
    """Replay times of the pick's key frames: pre-grasp reached, grasp closed, lifted, released."""
    seg = plan.segment_times()
    keys = [k for k in ("transit", "close", "lift", "release") if k in seg]
    return tuple(float(seg[k][1]) for k in keys)
