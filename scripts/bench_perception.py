"""Benchmark of the table-top segmentation of a 640x480 depth frame.

For each synthetic scene (3, 4 and 6 objects with stereo-like depth noise) it measures the
compile time of the RANSAC kernel, the first call, and the steady per-frame time of
``symjax.perception.segmentation`` on the depth image, and, as the reference measured in the same
run, the same scene segmented from its point cloud (voxel grid + k-d tree Euclidean clustering,
the PCL approach the paper's UJI platform uses). Prints one JSON line per case and writes
``bench/results/perception.json`` atomically.

Usage: ``python scripts/bench_perception.py [--repeats 20]``
"""

from __future__ import annotations

import dataclasses
import json
import os
import platform
import statistics
import sys
import time
from pathlib import Path

import numpy as np

from symjax.cli.common import PresetArgs, parse

FLOOR_MS = 150.0


def _timed(fn, repeats: int) -> list[float]:
    out = []
    for _ in range(repeats):
        t = time.perf_counter()
        fn()
        out.append(time.perf_counter() - t)
    return out


def _iou_ok(scene, result) -> tuple[int, float]:
    from scipy.optimize import linear_sum_assignment

    n = int(scene.truth.max()) + 1
    if n == 0 or not len(result):
        return len(result), 1.0 if n == len(result) else 0.0
    iou = np.zeros((n, len(result)))
    for i in range(n):
        t = scene.truth == i
        for j, o in enumerate(result.objects):
            m = np.asarray(o.mask)
            iou[i, j] = (t & m).sum() / max((t | m).sum(), 1)
    r, c = linear_sum_assignment(-iou)
    return len(result), float(iou[r, c].min()) if len(r) == n else 0.0


@dataclasses.dataclass(frozen=True)
class Args(PresetArgs):
    """Options of this benchmark."""

    repeats: int = 20
    """Timed repeats per case."""


def main(argv=None) -> int:
    args = parse(Args, sys.argv[1:] if argv is None else argv, "bench_perception.py", __doc__)

    import jax

    from symjax._atomic import atomic_write_json
    from symjax.perception import SegmentationConfig, segment
    from symjax.perception.ransac import plane_costs
    from symjax.perception.synthetic import tabletop_scene

    cfg = SegmentationConfig()
    # Compile time of the only jitted kernel, at the shapes segment() uses.
    t = time.perf_counter()
    plane_costs.lower(
        jax.ShapeDtypeStruct((cfg.ransac_sample, 3), np.float32),
        jax.ShapeDtypeStruct((cfg.ransac_hypotheses, 3), np.int32),
        np.float32(0),
        jax.ShapeDtypeStruct((3,), np.float32),
        np.float32(0),
    ).compile()
    compile_s = time.perf_counter() - t

    rows = []
    for i, n in enumerate((3, 4, 6)):
        scene = tabletop_scene(n, seed=10 + i, noise=0.002)
        t = time.perf_counter()
        res = segment(scene.depth, scene.camera, cfg)
        first_s = time.perf_counter() - t
        runs = _timed(lambda s=scene: segment(s.depth, s.camera, cfg), args.repeats)
        pts, valid = scene.camera.backproject(scene.depth)
        cloud = np.asarray(pts)[np.asarray(valid)]
        segment(cloud, scene.camera, cfg)
        ref = _timed(lambda c=cloud, s=scene: segment(c, s.camera, cfg), max(3, args.repeats // 4))
        found, min_iou = _iou_ok(scene, res)
        run_ms = 1000 * statistics.median(runs)
        ref_ms = 1000 * statistics.median(ref)
        row = {
            "case": f"depth_640x480_{n}_objects",
            "objects_true": n,
            "objects_found": found,
            "min_mask_iou": round(min_iou, 4),
            "compile_s": round(compile_s, 3),
            "first_call_s": round(first_s, 3),
            "run_ms_median": round(run_ms, 2),
            "run_ms_min": round(1000 * min(runs), 2),
            "run_ms_max": round(1000 * max(runs), 2),
            "repeats": args.repeats,
            "reference": "segment() on the frame's point cloud (voxel + k-d tree clustering)",
            "reference_ms_median": round(ref_ms, 2),
            "speedup_vs_reference": round(ref_ms / run_ms, 2),
            "floor_ms": FLOOR_MS,
            "meets_floor": run_ms <= FLOOR_MS,
        }
        rows.append(row)
        print(json.dumps(row), flush=True)

    out = Path(__file__).resolve().parents[1] / "bench" / "results" / "perception.json"
    atomic_write_json(
        out,
        {
            "benchmark": "perception",
            "machine": {
                "cpu_count": os.cpu_count(),
                "platform": platform.platform(),
                "jax_backend": jax.default_backend(),
            },
            "cases": rows,
        },
    )


if __name__ == "__main__":
    sys.exit(main())
