"""Benchmark of ``PlanArmTrajectory`` (issue 14) for both robots, with and without obstacles.

Cases (one JSON line each, all rows to ``bench/results/motion.json``, written atomically):

* ``ik``: mink IK from home to TCP poses of random configurations near home: solves per second
  and time to convergence (median, p95).
* ``rrt``: RRT-Connect queries between random collision-free configurations, the direct-line
  shortcut off: planning time per query (median, p95) and the solved share.
* ``plan_arm``: the whole pick per stable grasp on seeded table scenes (``--scenes`` per robot,
  2 to 5 objects: the datasets module's box, cylinder and bottle, each object the target in
  turn, the others obstacles; grasps from ``symjax.grasp.plan`` with C MuJoCo): status shares,
  time per grasp (median, p95), and for up to ``--replays`` ok plans per object the replay in C
  MuJoCo: arm or hand contacts with the table or other objects, TCP error at the grasp.

Every row gives the load average and, as the reference timed in the same run, one collision
check of the planning scene (``ratio_to_check`` = time / that check).

Usage: ``python scripts/bench_motion.py [--scenes 10] [--replays 3]
[--out bench/results/motion.json]``
"""

from __future__ import annotations

import dataclasses
import json
import os
import platform
import sys
import time
from pathlib import Path

import numpy as np
import trimesh

from symjax import motion
from symjax._atomic import atomic_write_json
from symjax._timing import median_p95
from symjax.cli.common import PresetArgs, parse

ROOT = Path(__file__).resolve().parents[1]


def _bottle():
    # The datasets' bottle stands on the pole of its ellipsoid, which a simulated table does not
    # hold (it topples in the replay): cut 2 cm off its bottom so that it stands.
    v = trimesh.creation.icosphere(3).apply_scale((0.045, 0.028, 0.08)).vertices
    body = trimesh.PointCloud(np.c_[v[:, :2], np.maximum(v[:, 2], -0.06)]).convex_hull
    neck = trimesh.creation.cylinder(0.012, 0.06, sections=16).apply_translation((0, 0, 0.10))
    return [body, neck]


SHAPES = {  # the datasets module's primitive objects (symjax.datasets.primitives), as meshes
    "box": lambda: [trimesh.creation.box((0.12, 0.07, 0.10))],
    "cylinder": lambda: [trimesh.creation.cylinder(0.035, 0.12, sections=24)],
    "bottle": _bottle,
}


@dataclasses.dataclass(frozen=True)
class Args(PresetArgs):
    scenes: int = 10
    """Table scenes per robot."""
    replays: int = 3
    """Replays of ok plans per target object."""
    queries: int = 40
    """IK and RRT queries per case."""
    out: str = str(ROOT / "bench" / "results" / "motion.json")


def _stats(x) -> dict:
    return median_p95(x)


def _box(size, centre):
    b = trimesh.creation.box(size)
    b.apply_translation(centre)
    return [(np.asarray(b.vertices), np.asarray(b.faces))]


def _obstacles(robot: str) -> dict:
    y = -0.2 if robot == "kth" else 0.2
    return {"post": _box((0.06, 0.06, 0.35), (0.65, y, 0.925)),
            "crate": _box((0.15, 0.15, 0.1), (0.8, -y, 0.8))}  # fmt: skip


def _check_time(scene) -> float:
    q = scene.full_q(scene.robot.home)
    t = time.perf_counter()
    for _ in range(2000):
        scene.is_valid(q)
    return (time.perf_counter() - t) / 2000


def bench_ik(robot: str, obstacles: bool, n: int, cfg) -> dict:
    scene = motion.PlanningScene(robot, _obstacles(robot) if obstacles else None)
    scene.margin = cfg.check_margin
    ik = motion.ArmIK(scene, cfg)
    rng = np.random.default_rng(0)
    home = np.asarray(scene.robot.home)
    q0 = scene.full_q(home)
    ik.solve(*scene.tcp_pose(q0), q0)  # warm up mink's caches
    times, iters, ok = [], [], 0
    for _ in range(n):
        p, R = scene.tcp_pose(scene.full_q(home + rng.uniform(-0.35, 0.35, len(home))))
        t = time.perf_counter()
        r = ik.solve(p, R, q0)
        dt = time.perf_counter() - t
        if r.converged:
            ok += 1
            times.append(dt)
            iters.append(r.iterations)
    check = _check_time(scene)
    med = float(np.median(times)) if times else float("nan")
    return {"case": "ik", "robot": robot, "obstacles": obstacles, "queries": n, "converged": ok,
            "solves_per_s": round(1.0 / med, 1), "seconds": _stats(times),
            "iterations": _stats(iters), "check_s": check,
            "ratio_to_check": round(med / check, 1)}  # fmt: skip


def bench_rrt(robot: str, obstacles: bool, n: int, cfg) -> dict:
    scene = motion.PlanningScene(robot, _obstacles(robot) if obstacles else None)
    scene.margin = cfg.check_margin
    rng = np.random.default_rng(1)
    home = np.asarray(scene.robot.home)
    pairs = []
    lo, hi = scene.scene_model().model.jnt_range[: len(home)].T
    while len(pairs) < n:
        a, b = (scene.full_q(np.clip(home + rng.uniform(-0.8, 0.8, len(home)), lo, hi))
                for _ in range(2))  # fmt: skip
        if scene.is_valid(a) and scene.is_valid(b):
            pairs.append((a, b))
    times, solved = [], 0
    for a, b in pairs:
        r = motion.plan_transit(scene, a, b, cfg, direct_first=False)
        times.append(r.seconds)
        solved += r.solved
    check = _check_time(scene)
    return {"case": "rrt", "robot": robot, "obstacles": obstacles, "queries": n, "solved": solved,
            "seconds": _stats(times), "check_s": check,
            "ratio_to_check": round(float(np.median(times)) / check, 1)}  # fmt: skip


def _place(rng, robot, k):
    """k non-overlapping footprints on the table inside the arm's reach (x, y, yaw)."""
    out = []
    while len(out) < k:
        x, y = rng.uniform(0.55, 0.8), rng.uniform(-0.3, 0.3)
        if all(np.hypot(x - a, y - b) > 0.14 for a, b, _ in out):
            out.append((x, y, rng.uniform(-np.pi, np.pi)))
    return out


def bench_scenes(robot: str, n_scenes: int, n_replays: int, cfg, preset) -> list[dict]:
    from symjax import grasp, hands, robots

    r = robots.load(robot)
    hand = hands.load(r.hand)
    table = r.table_height()
    gen = "uji" if robot == "uji" else "kth"
    plans = {}
    for kind, parts in SHAPES.items():  # one rollout batch per shape, in its own frame
        pieces = parts()
        lift = -min(p.bounds[0][2] for p in pieces)  # stand it on z = 0
        for p in pieces:
            p.apply_translation((0, 0, lift))
        mesh = trimesh.util.concatenate(pieces)
        hulls = [(np.asarray(p.vertices), np.asarray(p.faces)) for p in pieces]
        plans[kind] = (grasp.plan(mesh, hand, gen, hulls=hulls, table=0.0,
                                  candidates=preset.candidates, simulation=preset.simulation),
                       hulls)  # fmt: skip
    drop = np.asarray(r.dropoff[:2])
    rng = np.random.default_rng(14)
    status, times, ok_times, reasons, replays, rows = {}, [], [], {}, [], []
    skipped = 0
    s = -1
    while s + 1 - skipped < n_scenes and skipped < 5 * n_scenes:
        s += 1
        k = int(rng.integers(2, 6))
        kinds = [str(x) for x in rng.choice(list(SHAPES), k)]
        objects, poses = {}, {}
        for i, (kind, (x, y, yaw)) in enumerate(zip(kinds, _place(rng, robot, k), strict=True)):
            T = np.eye(4)
            T[:3, :3] = trimesh.transformations.rotation_matrix(yaw, (0, 0, 1))[:3, :3]
            T[:3, 3] = (x, y, table)
            objects[f"{kind}{i}"], poses[f"{kind}{i}"] = plans[kind][1], T
        scene = motion.PlanningScene(robot)
        scene.margin = cfg.check_margin
        for name, hulls in objects.items():
            scene.add_object(name, hulls, poses[name])
        home = np.asarray(r.home)
        if not all(scene.is_valid(scene.full_q(home, p)) for p in range(3)):
            skipped += 1
            continue  # an object under the hand at home: not a start the robot would be in; redrawn
        for name in objects:
            scene.target = name
            gp, T = plans[name.rstrip("0123456789")][0], poses[name]
            poses_w = [motion.GraspPose(
                (T[:3, :3] @ g.pregrasp[0] + T[:3, 3], T[:3, :3] @ g.pregrasp[1]),
                (T[:3, :3] @ g.grasp[0] + T[:3, 3], T[:3, :3] @ g.grasp[1]), g.preshape, g.index,
            ) for g in motion.grasp_poses(gp)]  # fmt: skip
            ok_plans = []
            for pl in motion.plan_arm_batch(scene, poses_w, config=cfg):
                status[pl.status] = status.get(pl.status, 0) + 1
                times.append(pl.seconds["total"])
                if pl.ok:
                    ok_plans.append(pl)
                    ok_times.append(pl.seconds["total"])
                else:
                    key = f"{pl.status}: {pl.reason.split(':')[0][:40]}"
                    reasons[key] = reasons.get(key, 0) + 1
            for pl in ok_plans[:n_replays]:
                rep = motion.replay(pl, scene, lift_height=cfg.lift_height)
                seg = pl.segment_times()

                def segment(t, seg=seg):
                    return next((k for k, (a, b) in seg.items() if a <= t <= b + 0.01), "settle")

                replays.append({"scene": s, "target": name, "collisions": len(rep.collisions),
                                "contacts": [(*c[:2], segment(c[2]), round(1e3 * c[3], 2))
                                             for c in rep.collisions][:4],
                                "tcp_error_mm": round(1e3 * rep.tcp_error, 2),
                                "lifted": rep.lifted, "slip_mm": round(1e3 * rep.slip, 1),
                                # The cycle's test: released over the drop-off, off the table.
                                "delivered": bool(np.hypot(*(rep.target_released[:2] - drop)) < 0.2
                                                  and rep.target_final[2] < table - 0.02),
                                "rests_near_dropoff": bool(
                                    np.hypot(*(rep.target_final[:2] - drop)) < 0.2),
                                "tracking_rad": round(rep.max_tracking_error, 4)})  # fmt: skip
    n = sum(status.values())
    tcp = [x["tcp_error_mm"] for x in replays]
    rows.append({
        "case": "plan_arm", "robot": robot, "scenes": s + 1 - skipped,
        "scenes_redrawn_home_in_collision": skipped, "stable_grasps": n,
        "status_share": {k: round(v / max(n, 1), 3) for k, v in sorted(status.items())},
        "seconds_per_grasp": _stats(times), "seconds_per_ok_plan": _stats(ok_times),
        "failure_reasons": dict(sorted(reasons.items(), key=lambda kv: -kv[1])[:6]),
        "replays": len(replays),
        "replays_with_collision": sum(x["collisions"] > 0 for x in replays),
        "tcp_error_mm": _stats(tcp), "tcp_error_under_5mm": sum(t < 5 for t in tcp),
        "lifted": sum(x["lifted"] for x in replays),
        "delivered": sum(x["delivered"] for x in replays),
        "rests_near_dropoff": sum(x["rests_near_dropoff"] for x in replays),
        "slip_mm": _stats([x["slip_mm"] for x in replays]),
        "collision_examples": [x for x in replays if x["collisions"]][:3],
    })  # fmt: skip
    return rows


def main(argv=None) -> int:
    args = parse(Args, sys.argv[1:] if argv is None else argv, "bench_motion.py", __doc__)
    from symjax import configs

    preset = configs.load(args.config)
    cfg = preset.motion
    env = {"load_avg": [round(x, 2) for x in os.getloadavg()], "cpu": platform.processor() or
           platform.machine(), "cores": os.cpu_count()}  # fmt: skip
    rows = []
    for robot in ("kth", "uji"):
        for obstacles in (False, True):
            for fn in (bench_ik, bench_rrt):
                row = {**fn(robot, obstacles, args.queries, cfg), **env}
                print(json.dumps(row), flush=True)
                rows.append(row)
        if args.scenes:
            for row in bench_scenes(robot, args.scenes, args.replays, cfg, preset):
                row = {**row, **env, "load_avg_end": [round(x, 2) for x in os.getloadavg()]}
                print(json.dumps(row), flush=True)
                rows.append(row)
    atomic_write_json(args.out, rows)
    return 0


if __name__ == "__main__":
    sys.exit(main())
