"""Benchmark of the evaluation's stages (issue 19): one JSON line per case.

* ``mesh_deviation``: ``symjax.metrics.mesh_deviation`` with 5,000 reference samples against a
  50k-face mesh (a scaled ellipsoid, smooth like a Mir7 mesh) and against the Delaunay baseline
  of a benchmark view (long side walls). The reference, timed in the same run on the same
  points, is the exact search it replaced (a k-d tree of face centroids, every ball query
  widened by the largest triangle); ``max_abs_diff_m`` is the largest difference of the
  distances. The libigl AABB tree is built inside the timed call (a new mesh each time).
* ``search_batch``: the default search over the first 32 benchmark views in batches of 16,
  per view after a warm-up pass (the compile), at the default ``symmetry_chunk_views`` (2)
  against the former default (4) in the same run, and whether the planes are identical.
* ``eval_stages`` (with ``--before DIR --after DIR``): the stage totals of two ``symjax eval``
  runs over the 128 views (``results.json``), before and after, their ratio, and whether the
  printed summary is the same.

Usage: ``python scripts/bench_eval.py [--before out/eval_before --after out/eval_after]``
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

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from symjax.cli.common import PresetArgs, parse  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]


@dataclasses.dataclass(frozen=True)
class Args(PresetArgs):
    """Options of this benchmark."""

    before: str | None = None
    """An earlier ``symjax eval`` output folder."""
    after: str | None = None
    """A later one, of the same settings."""
    repeats: int = 5
    """Timed calls per case (the best is reported)."""
    out: str = str(ROOT / "bench" / "results" / "eval.json")
    """Where the JSON lines go."""


def _closest_on_triangles(tri: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Closest points on triangles (M, 3, 3) to points (M, 3) (Ericson, RTCD 5.1.5)."""
    a, b, c = tri[:, 0], tri[:, 1], tri[:, 2]
    ab, ac, ap, bp, cp = b - a, c - a, q - a, q - b, q - c

    def dot(x, y):
        return np.einsum("ij,ij->i", x, y)

    d1, d2, d3, d4, d5, d6 = (
        dot(ab, ap),
        dot(ac, ap),
        dot(ab, bp),
        dot(ac, bp),
        dot(ab, cp),
        dot(ac, cp),
    )
    va, vb, vc = d3 * d6 - d5 * d4, d5 * d2 - d1 * d6, d1 * d4 - d3 * d2
    denom = va + vb + vc
    denom = np.where(np.abs(denom) < 1e-300, 1e-300, denom)
    out = a + ab * (vb / denom)[:, None] + ac * (vc / denom)[:, None]

    def seg(mask, p0, d, t):
        t = np.clip(np.nan_to_num(t), 0.0, 1.0)
        return np.where(mask[:, None], p0 + d * t[:, None], out)

    with np.errstate(divide="ignore", invalid="ignore"):
        out = seg((va <= 0) & (d4 - d3 >= 0) & (d5 - d6 >= 0), b, c - b,
                  (d4 - d3) / ((d4 - d3) + (d5 - d6)))  # fmt: skip
        out = seg((vb <= 0) & (d2 >= 0) & (d6 <= 0), a, ac, d2 / (d2 - d6))
        out = seg((vc <= 0) & (d1 >= 0) & (d3 <= 0), a, ab, d1 / (d1 - d3))
    out = np.where(((d6 >= 0) & (d5 <= d6))[:, None], c, out)
    out = np.where(((d3 >= 0) & (d4 <= d3))[:, None], b, out)
    return np.where(((d1 <= 0) & (d2 <= 0))[:, None], a, out)


def reference_distance(p: np.ndarray, mesh) -> np.ndarray:
    """The exact search symjax used before (k-d tree of centroids, global radius bound)."""
    from scipy.spatial import cKDTree

    tri = np.asarray(mesh.triangles, np.float64)
    cen = tri.mean(axis=1)
    tree = cKDTree(cen)
    rad = float(np.max(np.linalg.norm(tri - cen[:, None, :], axis=-1)))
    out = np.empty(len(p))
    for s in range(0, len(p), 4096):
        q = p[s : s + 4096]
        d0, _ = tree.query(q)
        cand = tree.query_ball_point(q, d0 + rad + 1e-12)
        counts = np.array([len(c) for c in cand])
        faces = np.concatenate([np.asarray(c, dtype=np.int64) for c in cand])
        owner = np.repeat(np.arange(len(q)), counts)
        d = np.linalg.norm(_closest_on_triangles(tri[faces], q[owner]) - q[owner], axis=1)
        out[s : s + 4096] = np.minimum.reduceat(d, np.concatenate([[0], np.cumsum(counts)[:-1]]))
    return out


def _meshes():
    import trimesh

    from symjax.datasets import benchmark
    from symjax.surface import delaunay_mesh

    ell = trimesh.creation.icosphere(subdivisions=6, radius=0.05)
    ell = trimesh.Trimesh(ell.vertices * [1.0, 1.06, 0.94], ell.faces)
    ell = ell.simplify_quadric_decimation(face_count=50000)
    ref_ell = trimesh.creation.icosphere(subdivisions=5, radius=0.05)
    view = benchmark(["003_cracker_box/000"])[0]
    obs = view.observation
    de = delaunay_mesh(obs.points, obs.camera)
    return [("ellipsoid_50k", ref_ell, ell), ("delaunay_cracker_box", view.gt_mesh, de)]


def main(argv=None) -> int:
    import trimesh

    from symjax._timing import JsonRows
    from symjax.metrics import mesh_deviation, sample_surface, surface_distance

    args = parse(Args, sys.argv[1:] if argv is None else argv, "bench_eval.py", __doc__)
    meta = {"machine": platform.machine(), "cpus": os.cpu_count()}
    emit = JsonRows(args.out, meta).emit

    for name, ref_mesh, mesh in _meshes():
        load0 = [round(x, 2) for x in os.getloadavg()]
        pts = sample_surface(ref_mesh, 5000, seed=0)
        new_s, ref_s = [], []
        for _ in range(args.repeats):
            fresh = trimesh.Trimesh(mesh.vertices, mesh.faces, process=False)  # no cached tree
            t0 = time.perf_counter()
            mesh_deviation(ref_mesh, fresh, n_samples=5000, seed=0)
            new_s.append(time.perf_counter() - t0)
        d_new = surface_distance(pts, trimesh.Trimesh(mesh.vertices, mesh.faces, process=False))
        for _ in range(min(args.repeats, 2)):
            t0 = time.perf_counter()
            d_ref = reference_distance(pts, mesh)
            ref_s.append(time.perf_counter() - t0)
        emit({
            "case": "mesh_deviation", "mesh": name, "faces": len(mesh.faces), "samples": 5000,
            "run_s": round(min(new_s), 4), "reference_s": round(min(ref_s), 4),
            "speedup": round(min(ref_s) / min(new_s), 1), "target_s": 0.05,
            "max_abs_diff_m": float(np.abs(d_new - d_ref).max()),
            "implementation": "libigl AABB tree (igl.AABB.squared_distance, float64)",
            "load_avg": load0,
        })  # fmt: skip
    emit(_bench_search())
    if args.before and args.after:
        runs = {}
        for tag, folder in (("before", args.before), ("after", args.after)):
            d = json.loads((Path(folder) / "results.json").read_text())
            runs[tag] = d
        tb, ta = runs["before"]["summary"]["timings_s"], runs["after"]["summary"]["timings_s"]
        same = json.dumps(_printed(runs["before"]["summary"])) == json.dumps(
            _printed(runs["after"]["summary"]))  # fmt: skip
        emit({
            "case": "eval_stages", "rows": len(runs["after"]["rows"]),
            "before_s": {k: round(v, 2) for k, v in tb.items()},
            "after_s": {k: round(v, 2) for k, v in ta.items()},
            "ratio": {k: round(tb[k] / ta[k], 2) for k in tb if k in ta and ta[k] > 0},
            "run_before_s": round(runs["before"]["run"]["run_s"], 1),
            "run_after_s": round(runs["after"]["run"]["run_s"], 1),
            "summary_unchanged_to_the_printed_digit": same,
        })  # fmt: skip
    return 0


def _bench_search() -> dict:
    from symjax.datasets import benchmark
    from symjax.execution import ExecutionConfig
    from symjax.symmetry import SymmetryConfig, search_batch

    obs = [v.observation for v in benchmark(None)][:32]
    cfg = SymmetryConfig()
    load0 = [round(x, 2) for x in os.getloadavg()]
    per, planes = {}, {}
    for width in (2, 4):
        ex = ExecutionConfig(symmetry_chunk_views=width)
        for s in (0, 16):
            search_batch(obs[s : s + 16], cfg, ex)  # compile
        t0 = time.perf_counter()
        res = [search_batch(obs[s : s + 16], cfg, ex) for s in (0, 16)]
        per[width] = (time.perf_counter() - t0) / len(obs)
        planes[width] = np.concatenate([np.asarray(r.normal) for r in res])
    return {
        "case": "search_batch", "views": len(obs), "hypotheses": 350,
        "run_s_per_view": round(per[2], 4), "reference_s_per_view_chunk4": round(per[4], 4),
        "speedup": round(per[4] / per[2], 2),
        "planes_identical": bool(np.array_equal(planes[2], planes[4])),
        "load_avg": load0,
    }  # fmt: skip


def _printed(summary: dict) -> dict:
    """The summary's numbers as the report prints them (3 significant digits), timings out."""

    def r(x):
        if isinstance(x, dict):
            return {k: r(v) for k, v in x.items() if k != "timings_s"}
        if isinstance(x, list):
            return [r(v) for v in x]
        if isinstance(x, float):
            return float(f"{x:.3g}")
        return x

    return r(summary)


if __name__ == "__main__":
    sys.exit(main())
