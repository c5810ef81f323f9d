"""Benchmark of one object through the whole grasp cycle (issue 15): frame to executed pick.

Cases (one JSON line each, all rows to ``bench/results/cycle.json``, written atomically): per
robot and mode, ``--scenes`` seeded scenes of one scan each. The first scene of a process pays
for compiling (the symmetry search, the Poisson solve, the rollouts' schedule and labels): it is
reported apart as ``first_s``; ``pick_s`` (median, p95) is over the scenes after it that
executed a pick. Per stage of Algorithm 1 the median seconds of those picks. Reference timed in
the same run: ``GetObjectHypotheses`` on the scene's frame (``ratio_to_segment``). Every row gives
the load average.

Usage: ``python scripts/bench_cycle.py [--scenes 6] [--out bench/results/cycle.json]``
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

from symjax._atomic import atomic_write_json
from symjax._timing import median_p95
from symjax.cli.common import PresetArgs, parse

ROOT = Path(__file__).resolve().parents[1]


@dataclasses.dataclass(frozen=True)
class Args(PresetArgs):
    config: str = "cycle"
    scenes: int = 6
    """One-object scenes per robot and mode (the first one compiles)."""
    modes: tuple[str, ...] = ("C",)
    """Modes to time (C, P, T)."""
    out: str = str(ROOT / "bench" / "results" / "cycle.json")


def _stats(x) -> dict:
    return median_p95(x, 3)


def main(argv=None) -> int:
    args = parse(Args, sys.argv[1:] if argv is None else argv, "bench_cycle.py", __doc__)
    from symjax import configs, cycle, datasets, perception

    preset = configs.load(args.config)
    env = {"cpu": platform.processor() or platform.machine(), "cores": os.cpu_count()}
    rows = []
    for robot in ("kth", "uji"):
        for mode in args.modes:
            cfg = cycle.CycleConfig.from_preset(preset, mode=mode)
            load0 = [round(x, 2) for x in os.getloadavg()]
            picks, stages, first, seg, cleared, collisions = [], {}, None, [], 0, 0
            for s in range(args.scenes):
                scene = datasets.scan_scene(robot, 1, seed=100 + s)
                t0 = time.perf_counter()
                rep = cycle.clear_table(scene, robot, cfg)
                wall = time.perf_counter() - t0
                t1 = time.perf_counter()
                perception.segment(scene.depth, scene.camera, cfg.segmentation)
                seg.append(time.perf_counter() - t1)
                cleared += rep.n_cleared
                collisions += rep.collisions
                if s == 0:
                    first = wall
                    continue
                for r in rep.rounds:
                    if r.execution is not None:
                        picks.append(r.total_seconds)
                        for k, v in r.seconds.items():
                            stages.setdefault(k, []).append(v)
            med = _stats(picks)["median"]
            ref = float(np.median(seg))
            row = {"case": "one_object_cycle", "robot": robot, "mode": mode,
                   "scenes": args.scenes, "cleared": cleared, "collisions": collisions,
                   "first_s": round(first, 2), "pick_s": _stats(picks), "picks": len(picks),
                   "stage_s_median": {k: _stats(v)["median"] for k, v in stages.items()},
                   "segment_s": round(ref, 4),
                   "ratio_to_segment": round(med / ref, 1) if med else None,
                   "load_avg": load0, "load_avg_end": [round(x, 2) for x in os.getloadavg()],
                   **env}  # fmt: skip
            print(json.dumps(row), flush=True)
            rows.append(row)
    atomic_write_json(args.out, rows)
    return 0


if __name__ == "__main__":
    sys.exit(main())
