"""Benchmark of the embedded 128-view data set (issue 5): one JSON line per case.

Cases:
  object         one line per data set: size (cm), symmetry kind, verified planes and their
                 mirrored-mesh deviation (mm), preprocessing time (s).
  generate_128   generating all 16 x 8 views into an empty cache (objects preprocessed too),
                 with a process pool; acceptance: at most 120 s on the 2-core CPU.
  generate_views the same with the objects already cached (the views alone).
  reuse_128      ``benchmark()`` on the filled cache (index check only) and loading all views.
  render_view    median time of one view in process (no storage).
  clouds         cloud sizes over the 128 views (paper: 2k-40k points), flying pixels, and the
                 largest distance of a non-flying point to the ground-truth surface relative to the
                 noise model's bound (must be <= 1).

Results go to ``bench/results/dataset.json`` (written atomically).

Usage: ``python scripts/bench_dataset.py [--workers 2] [--out bench/results/dataset.json]``
"""

from __future__ import annotations

import dataclasses
import json
import math
import os
import platform
import shutil
import statistics
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from symjax._atomic import atomic_write_json
from symjax.cli.common import PresetArgs, parse  # noqa: E402
from symjax.datasets import (
    DATASET_IDS,
    BenchmarkConfig,
    benchmark,
    load_dataset_object,
    render_view,
)
from symjax.metrics import surface_distance

ROOT = Path(__file__).resolve().parents[1]
LIMIT_S = 120.0


@dataclasses.dataclass(frozen=True)
class Args(PresetArgs):
    """Options of this benchmark."""

    out: str = str(ROOT / "bench" / "results" / "dataset.json")
    """Where the JSON lines go."""
    workers: int | None = None
    """Rendering processes (None: one per core, at most 8)."""
    seed: int = 0
    """Benchmark rendering seed."""


def main(argv=None) -> int:
    args = parse(Args, sys.argv[1:] if argv is None else argv, "bench_dataset.py", __doc__)
    env = {
        "cpu": platform.processor() or platform.machine(),
        "cpus": os.cpu_count(),
        "load_avg_1m": round(os.getloadavg()[0], 2),
        "python": sys.version.split()[0],
    }
    rows = []

    def emit(row):
        row = {**row, **env}
        rows.append(row)
        print(json.dumps(row), flush=True)

    tmp = Path(tempfile.mkdtemp(prefix="symjax-bench-"))
    try:
        # generate_128: everything from scratch.
        t0 = time.perf_counter()
        bench = benchmark(cache_dir=tmp, seed=args.seed, workers=args.workers)
        t_all = time.perf_counter() - t0
        emit(
            {
                "case": "generate_128",
                "views": len(bench),
                "seconds": round(t_all, 2),
                "limit_s": LIMIT_S,
                "meets_limit": t_all <= LIMIT_S,
                "workers": args.workers or os.cpu_count(),
                "cache_mb": round(sum(f.stat().st_size for f in tmp.rglob("*")) / 2**20, 1),
                "load_avg_1m_after": round(os.getloadavg()[0], 2),
            }
        )

        # generate_views: objects cached, views regenerated.
        shutil.rmtree(bench.folder)
        t0 = time.perf_counter()
        bench = benchmark(cache_dir=tmp, seed=args.seed, workers=args.workers)
        t_views = time.perf_counter() - t0
        emit(
            {
                "case": "generate_views",
                "views": len(bench),
                "seconds": round(t_views, 2),
                "limit_s": LIMIT_S,
                "meets_limit": t_views <= LIMIT_S,
            }
        )

        # reuse_128.
        t0 = time.perf_counter()
        bench = benchmark(cache_dir=tmp, seed=args.seed)
        t_index = time.perf_counter() - t0
        t0 = time.perf_counter()
        views = list(bench)
        t_load = time.perf_counter() - t0
        emit(
            {
                "case": "reuse_128",
                "index_s": round(t_index, 4),
                "load_all_s": round(t_load, 2),
                "views": len(views),
            }
        )

        # object: sizes and symmetry (from the cache filled above; timing from a fresh run).
        for ds in DATASET_IDS:
            t0 = time.perf_counter()
            obj = load_dataset_object(ds, cache_dir=None)
            dt = time.perf_counter() - t0
            sym = obj.symmetry
            emit(
                {
                    "case": "object",
                    "dataset": ds,
                    "size_cm": [round(float(x) * 100, 1) for x in obj.size],
                    "watertight": obj.watertight,
                    "faces": len(obj.mesh.faces),
                    "symmetry": sym.kind,
                    "planes": [
                        {
                            "normal": [round(v, 4) for v in n],
                            "offset_mm": round(o * 1e3, 2),
                            "deviation_mm": round(d * 1e3, 2),
                        }
                        for (n, o), d in zip(sym.planes, sym.deviations, strict=False)
                    ]
                    if sym.kind == "planar"
                    else [],
                    "rotational_max_deviation_mm": round(sym.deviations[0] * 1e3, 2)
                    if sym.kind == "rotational"
                    else None,
                    "best_plane_deviation_mm": round(sym.best_deviation * 1e3, 2),
                    "preprocess_s": round(dt, 2),
                }
            )

        # render_view: one view in process.
        obj = load_dataset_object("003_cracker_box", cache_dir=tmp)
        cfg = BenchmarkConfig()
        render_view(obj, 0.0, args.seed, cfg)
        times = []
        for o in cfg.orientations_deg:
            t0 = time.perf_counter()
            render_view(obj, o, args.seed, cfg)
            times.append(time.perf_counter() - t0)
        emit(
            {
                "case": "render_view",
                "dataset": "003_cracker_box",
                "median_s": round(statistics.median(times), 3),
            }
        )

        # clouds: sizes, flying pixels and the noise bound over all views.
        head, noise = cfg.head, cfg.noise
        f = math.sqrt(head.fx * head.fy)
        n_pts, n_fly, worst, violations = [], [], 0.0, 0
        for v in views:
            pts = v.points.astype(np.float64)
            xc = np.asarray(v.camera.world_to_camera(pts), np.float64)
            factor = np.linalg.norm(xc, axis=1) / xc[:, 2]
            bound = noise.depth_bound(xc[:, 2] * 1.02, f, head.baseline) * factor + 1e-5
            d = surface_distance(pts, v.gt_mesh, candidates=12)
            ok = ~v.flying
            worst = max(worst, float((d[ok] / bound[ok]).max()))
            violations += int((d[ok] > bound[ok]).sum())
            n_pts.append(len(pts))
            n_fly.append(int(v.flying.sum()))
        emit(
            {
                "case": "clouds",
                "views": len(views),
                "points_min": min(n_pts),
                "points_median": int(statistics.median(n_pts)),
                "points_max": max(n_pts),
                "within_2k_40k": all(2000 <= n <= 40000 for n in n_pts),
                "flying_per_view_max": max(n_fly),
                "flying_total": sum(n_fly),
                "worst_distance_over_bound": round(worst, 3),
                "bound_violations": violations,
            }
        )
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    atomic_write_json(args.out, rows)
    print(f"wrote {args.out}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
