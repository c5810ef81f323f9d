"""Benchmark of the convex decomposition of completed meshes (issue 15, defect 4).

For each view: the symmetry completion, Poisson depth 7 cut at the table (the mesh a grasp
planner gets), then coacd twice: on the full mesh with the round-one settings (the reference,
timed in the same run) and with the current :class:`DecomposeConfig` (quadric decimation to
``max_faces`` first). One JSON line per view: faces, seconds of each, the hulls' total volume
and its change, and the grasp labels of the same candidates (UJI generator, Barrett) simulated
on both hull sets (success rates and agreement). Rows go to ``bench/results/decompose.json``.

Usage: ``python scripts/bench_decompose.py [--views 8]``
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
from symjax.cli.common import PresetArgs, parse

ROOT = Path(__file__).resolve().parents[1]
VIEWS = ("006_mustard_bottle/000", "025_mug/090", "019_pitcher_base/045", "035_power_drill/000",
         "021_bleach_cleanser/135", "065-a_cups/000", "022_windex_bottle/090",
         "005_tomato_soup_can/045")  # fmt: skip


@dataclasses.dataclass(frozen=True)
class Args(PresetArgs):
    views: int = 8
    """Views (the first ones of a fixed list of the benchmark's)."""
    out: str = str(ROOT / "bench" / "results" / "decompose.json")


def _volume(hulls) -> float:
    from scipy.spatial import ConvexHull

    return float(sum(ConvexHull(v).volume for v, _ in hulls))


def main(argv=None) -> int:
    args = parse(Args, sys.argv[1:] if argv is None else argv, "bench_decompose.py", __doc__)
    from symjax import configs, datasets, grasp, hands
    from symjax.decompose import DecomposeConfig, decompose
    from symjax.surface import PoissonConfig, oriented_completion, poisson_reconstruct_batch
    from symjax.symmetry import search_batch

    preset = configs.load(args.config)
    env = {"load_avg": [round(x, 2) for x in os.getloadavg()], "cpu": platform.processor() or
           platform.machine(), "cores": os.cpu_count()}  # fmt: skip
    views = datasets.benchmark(list(VIEWS[: args.views]))
    res = search_batch([v.observation for v in views])
    ops = [oriented_completion(res[i], v.camera) for i, v in enumerate(views)]
    meshes = poisson_reconstruct_batch(ops, PoissonConfig(depth=7),
                                       tables=[v.observation.table for v in views])  # fmt: skip
    # Round one's settings: coacd on the full mesh.
    reference = DecomposeConfig(threshold=0.08, max_hulls=16, max_vertices=64, resolution=2000,
                                preprocess_resolution=50, mcts_iterations=100, max_faces=0,
                                preprocess="auto", mcts_max_depth=3, mcts_nodes=20)  # fmt: skip
    current = preset.decompose
    hand = hands.load("barrett")
    rows = []
    for v, mesh in zip(views, meshes, strict=True):
        t = time.perf_counter()
        ref = decompose(mesh, reference, use_cache=False)
        t_ref = time.perf_counter() - t
        t = time.perf_counter()
        new = decompose(mesh, current, use_cache=False)
        t_new = time.perf_counter() - t
        table = v.observation.table
        cands = grasp.generate(mesh, "uji", config=preset.candidates, table=table,
                               hand=hand).candidates  # fmt: skip
        out = {}
        for name, dec in (("reference", ref), ("simplified", new)):
            o = grasp.simulate(dec, cands, hand, preset.simulation, backend="mujoco", table=table)
            out[name] = np.asarray(o.numpy().success)
        row = {
            "case": "decompose", "view": v.name, "faces": int(len(mesh.faces)),
            "hulls": [ref.n_hulls, new.n_hulls],
            "seconds": {"reference": round(t_ref, 2), "simplified": round(t_new, 2)},
            "speedup": round(t_ref / max(t_new, 1e-9), 1),
            "volume_cm3": {"mesh": round(1e6 * mesh.volume, 1),
                           "reference": round(1e6 * _volume(ref.hulls), 1),
                           "simplified": round(1e6 * _volume(new.hulls), 1)},
            "volume_change": round(_volume(new.hulls) / _volume(ref.hulls) - 1.0, 4),
            "candidates": int(len(cands)),
            "success": {k: round(float(x.mean()), 3) for k, x in out.items()},
            "label_agreement": round(float((out["reference"] == out["simplified"]).mean()), 3),
            **env,
        }  # fmt: skip
        print(json.dumps(row), flush=True)
        rows.append(row)
    t_new = [r["seconds"]["simplified"] for r in rows]
    summary = {
        "case": "summary", "views": len(rows),
        "simplified_s": {"median": float(np.median(t_new)), "max": float(np.max(t_new))},
        "reference_s": {"median": float(np.median([r["seconds"]["reference"] for r in rows]))},
        "volume_change_median": float(np.median([r["volume_change"] for r in rows])),
        "label_agreement_mean": float(np.mean([r["label_agreement"] for r in rows])),
        "load_avg_end": [round(x, 2) for x in os.getloadavg()], **env,
    }  # fmt: skip
    print(json.dumps(summary), flush=True)
    atomic_write_json(args.out, [*rows, summary])
    return 0


if __name__ == "__main__":
    sys.exit(main())
