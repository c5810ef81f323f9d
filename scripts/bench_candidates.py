"""Benchmark of ConvexDecomposition + GetGraspCandidates per object (issue 7): one JSON line each.

Paper Section IV: generating the reduced candidate set takes under a minute; OpenRAVE's default
set takes minutes to an hour to simulate. Per object this reports the coacd time (cold, cache
off), the cache-hit time, and for each generator the candidate count, drops and the time of the
first call (JAX compilation included) and of a second call (compiled). Results go to
``bench/results/candidates.json``.

Usage: ``python scripts/bench_candidates.py [--out bench/results/candidates.json]``
"""

from __future__ import annotations

import dataclasses
import json
import platform
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import trimesh

from symjax import grasp, hands
from symjax._atomic import atomic_write_json
from symjax.cli.common import PresetArgs, parse  # noqa: E402
from symjax.decompose import DecomposeConfig, decompose
from symjax.table import TablePlane

ROOT = Path(__file__).resolve().parents[1]


def objects() -> dict[str, trimesh.Trimesh]:
    bottle = trimesh.creation.cylinder(0.035, 0.2, sections=48)
    bottle.apply_translation([0.6, 0.0, 0.1])
    box = trimesh.creation.box([0.16, 0.06, 0.05])
    box.apply_translation([0.5, 0.1, 0.025])
    mug = trimesh.creation.annulus(0.03, 0.045, 0.1, sections=48)
    mug.apply_translation([0.6, -0.1, 0.05])
    sphere = trimesh.creation.icosphere(subdivisions=4, radius=0.05)
    sphere.apply_translation([0.6, 0.0, 0.05])
    return {"bottle": bottle, "box": box, "mug": mug, "sphere": sphere}


@dataclasses.dataclass(frozen=True)
class Args(PresetArgs):
    """Options of this benchmark."""

    out: str = str(ROOT / "bench" / "results" / "candidates.json")
    """Where the JSON lines go."""


def main(argv=None) -> int:
    args = parse(Args, sys.argv[1:] if argv is None else argv, "bench_candidates.py", __doc__)
    table = TablePlane.horizontal(0.0)
    hand = hands.load("sdh")
    cfg = DecomposeConfig()
    rows = []
    with tempfile.TemporaryDirectory() as cache:
        for name, mesh in objects().items():
            v, f = np.asarray(mesh.vertices), np.asarray(mesh.faces)
            cold = decompose((v, f), cfg, cache_dir=cache)
            hit = decompose((v, f), cfg, cache_dir=cache)
            for method in grasp.METHODS:
                t0 = time.perf_counter()
                grasp.generate((v, f), method, table=table, hand=hand)
                first = time.perf_counter() - t0
                s = grasp.generate((v, f), method, table=table, hand=hand)
                row = {
                    "object": name,
                    "faces": int(len(f)),
                    "method": method,
                    "coacd_s": round(cold.seconds, 3),
                    "coacd_cache_hit_s": round(hit.seconds, 4),
                    "cache_hit": hit.cache_hit,
                    "n_hulls": cold.n_hulls,
                    "max_hull_vertices": max(len(hv) for hv, _ in cold.hulls),
                    "n_candidates": len(s),
                    "n_generated": s.n_generated,
                    "n_dropped_table": s.n_dropped_table,
                    "n_dropped_object": s.n_dropped_object,
                    "candidates_first_s": round(first, 3),
                    "candidates_s": round(s.seconds, 3),
                    "total_s": round(cold.seconds + s.seconds, 3),
                }
                print(json.dumps(row), flush=True)
                rows.append(row)
    atomic_write_json(
        args.out,
        {"machine": platform.platform(), "processor": platform.processor(), "cases": rows},
    )


if __name__ == "__main__":
    sys.exit(main())
