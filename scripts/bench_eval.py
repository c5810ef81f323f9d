"""Benchmark of the evaluation's stages (issue 19): one JSON line per case.

* ``mesh_deviation``: ``symjax.metrics.mesh_deviation`` with 5,000 reference samples against a
  50k-face mesh (a scaled ellipsoid, smooth like a Mir7 mesh) and against the Delaunay baseline
  of a benchmark view (long side walls). The reference, timed in the same run on the same
  points, is the exact search it replaced (a k-d tree of face centroids, every ball query
  widened by the largest triangle); ``max_abs_diff_m`` is the largest difference of the
  distances. The closest-face tree (FCPW's BVH; libigl's AABB tree where FCPW has no wheel) is
  built inside the timed call (a new mesh each time).
* ``search_batch``: the default search over the first ``--search-views`` benchmark views (32) in
  batches of the preset's ``eval_batch_size`` (16; ``--config gpu``: the 128 views in one batch),
  per view after a warm-up pass, against the same views searched one by one (the reference),
  in 9 paired rounds of alternating order: medians and the median of the rounds' ratios.
* ``poisson7_view``: a Poisson depth-7 mesh per view after compilation (solve, marching cubes,
  table cut; views side by side in threads, or vmapped chunks with ``--config gpu``), on the
  completed clouds of the first 16 views.
* ``first_view``: a new process (``--probe first``) searches and meshes its first view; with an
  empty persistent compilation cache (cold) and again with the cache it left (warm: JAX's
  compiled programs and symjax's exported kernels, ``symjax._kernel_store``).
* ``compile_counts``: a new process searches and meshes views of 1,500 to 200,000 points and
  counts the compilations of each kernel against the number of point buckets.
* ``eval_run``: ``symjax eval --config <preset>`` over the 128 views in a new process, cold (empty
  compilation cache) and warm, wall time and stage totals (``--eval``).
* ``eval_stages`` (with ``--before DIR``): an earlier ``symjax eval`` run's stage totals against
  the warm run's, their ratio, and whether the report prints the same results.

Usage: ``python scripts/bench_eval.py [--eval] [--before out/eval_before]``; on a GPU machine
``python scripts/bench_eval.py --config gpu --search-views 128 --eval --no-compile-counts``
(``scripts/bench_gpu.py`` runs it).
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

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from symjax.cli.common import PresetArgs, parse  # noqa: E402
from symjax.execution import ExecutionConfig  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]


@dataclasses.dataclass(frozen=True)
class Args(PresetArgs):
    """Options of this benchmark."""

    before: str | None = None
    """An earlier ``symjax eval`` output folder (of the same settings) to compare with."""
    eval: bool = False
    """Run ``symjax eval`` cold and warm (about three minutes)."""
    probe: str | None = None
    """Internal: ``first`` or ``compiles``, run in a new process by the cases above."""
    repeats: int = 5
    """Timed calls per case (the best is reported)."""
    search_views: int = 32
    """Benchmark views of the ``search_batch`` case."""
    keep_eval: str | None = None
    """A folder to copy the warm ``symjax eval`` run's ``results.json`` and ``report.md`` to
    (as ``eval_results.json``, ``eval_report.md``), to compare with a run on another machine."""
    compile_counts: bool = True
    """Run the ``compile_counts`` probe (eight point buckets compiled in a new process)."""
    execution: ExecutionConfig = dataclasses.field(default_factory=ExecutionConfig)
    """Batching of the search, Poisson and eval cases (the preset's)."""
    out: str = str(ROOT / "bench" / "results" / "eval.json")
    """Where the JSON lines go."""


def reference_distance(p: np.ndarray, mesh) -> np.ndarray:
    """The exact search symjax used before (k-d tree of centroids, global radius bound)."""
    from scipy.spatial import cKDTree

    from symjax.geometry import closest_point_on_triangle

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
        d = np.linalg.norm(closest_point_on_triangle(q[owner], tri[faces]) - q[owner], axis=1)
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
    if args.probe:
        _run_probe(args.probe)
        return 0
    import jax

    meta = {"machine": platform.machine(), "cpus": os.cpu_count(), "preset": args.config,
            "jax_backend": jax.default_backend(), "device": str(jax.devices()[0])}  # fmt: skip
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
            "implementation": type(fresh.__dict__["_symjax_bvh"]).__name__,
            "load_avg": load0,
        })  # fmt: skip
    for row in _bench_search(args.search_views, args.execution):
        emit(row)
    emit(_bench_poisson(args.execution))
    emit(_bench_first_view())
    if args.compile_counts:
        emit(_probe("compiles", os.environ.get("JAX_COMPILATION_CACHE_DIR")))
    after = None
    if args.eval:
        for row in _bench_eval_runs(args.config):
            after = row.pop("_folder")
            emit(row)
        if args.keep_eval:
            import shutil

            Path(args.keep_eval).mkdir(parents=True, exist_ok=True)
            for name in ("results.json", "report.md"):
                shutil.copy(Path(after) / name, Path(args.keep_eval) / f"eval_{name}")
    if args.before and after:
        emit(_compare(args.before, after))
    return 0


def _bench_search(n_views: int, ex: ExecutionConfig, rounds: int = 9) -> list[dict]:
    """The batch against the same views one by one, in paired rounds.

    Each round times both, in alternating order (a slow spell of the shared host then lands on
    either side as often): the speedup is the median of the rounds' ratios, and ``batch_wins``
    says in how many rounds the batch was the faster. CPU time per view (all threads) is given
    too: on 2 cores the batch gains by keeping both busy, not by doing less.
    """
    from symjax.datasets import benchmark
    from symjax.symmetry import SymmetryConfig, search, search_batch

    obs = [v.observation for v in benchmark(None)][:n_views]
    cfg = SymmetryConfig()
    size = min(ex.eval_batch_size, len(obs))
    starts = range(0, len(obs), size)
    load0 = [round(x, 2) for x in os.getloadavg()]
    t0 = time.perf_counter()
    for s in starts:
        search_batch(obs[s : s + size], cfg, ex)  # compile
    first = time.perf_counter() - t0
    for o in obs:
        search(o, cfg)

    def batched():
        return [search_batch(obs[s : s + size], cfg, ex) for s in starts]

    def one_by_one():
        return [np.asarray(search(o, cfg).normal) for o in obs]

    times: dict[str, list] = {"batch": [], "single": []}
    cpu: dict[str, list] = {"batch": [], "single": []}
    last: dict = {}
    for r in range(rounds):
        pair = [("batch", batched), ("single", one_by_one)]
        for name, fn in pair if r % 2 == 0 else pair[::-1]:
            c0, t0 = time.process_time(), time.perf_counter()
            last[name] = fn()
            times[name].append((time.perf_counter() - t0) / len(obs))
            cpu[name].append((time.process_time() - c0) / len(obs))
    ratios = [s / b for s, b in zip(times["single"], times["batch"], strict=True)]
    planes = np.concatenate([np.asarray(r.normal) for r in last["batch"]])
    n = [len(o.points) for o in obs]
    med = statistics.median
    return [{
        "case": "search_batch", "views": len(obs), "points": [min(n), max(n)], "hypotheses": 350,
        "batch": size, "chunk_views": ex.symmetry_chunk_views,
        "first_pass_s": round(first, 2), "rounds": rounds,
        "run_s_per_view": round(med(times["batch"]), 4),
        "reference_s_per_view_one_by_one": round(med(times["single"]), 4),
        "speedup": round(med(ratios), 2),
        "speedup_range": [round(min(ratios), 2), round(max(ratios), 2)],
        "batch_wins": sum(x > 1.0 for x in ratios),
        "cpu_s_per_view": round(med(cpu["batch"]), 4),
        "reference_cpu_s_per_view": round(med(cpu["single"]), 4),
        "max_normal_diff_to_one_by_one": float(np.abs(planes - np.stack(last["single"])).max()),
        "load_avg": load0, "load_avg_end": [round(x, 2) for x in os.getloadavg()],
    }]  # fmt: skip


def _bench_poisson(ex: ExecutionConfig) -> dict:
    import dataclasses as dc

    from symjax.datasets import benchmark
    from symjax.surface import PoissonConfig, oriented_completion, poisson_reconstruct_batch
    from symjax.symmetry import search_batch

    bench = benchmark(None)
    views = [bench[i] for i in range(16)]
    res = search_batch([v.observation for v in views], execution=ex)
    ops = [oriented_completion(res[i], v.camera) for i, v in enumerate(views)]
    tables = [v.observation.table for v in views]
    load0 = [round(x, 2) for x in os.getloadavg()]
    out = {}
    for depth in (5, 7):
        cfg = dc.replace(PoissonConfig(), depth=depth)
        poisson_reconstruct_batch(ops, cfg, ex, tables=tables)  # compile
        t = []
        for _ in range(3):
            t0 = time.perf_counter()
            poisson_reconstruct_batch(ops, cfg, ex, tables=tables)
            t.append((time.perf_counter() - t0) / len(ops))
        out[depth] = min(t)
    return {
        "case": "poisson7_view", "views": len(ops),
        "points": [min(len(o.points) for o in ops), max(len(o.points) for o in ops)],
        "run_s_per_view": round(out[7], 4), "target_s": 0.1,
        "reference_depth5_s_per_view": round(out[5], 4),
        "chunk_views": ex.poisson_chunk_views,
        "what": "splat + FFT solve + marching cubes + table cut (chunk 1: one view a call, in"
                " threads; more: vmapped)",
        "load_avg": load0,
    }  # fmt: skip


def _probe(kind: str, cache: str | None) -> dict:
    """Runs ``--probe kind`` in a new process with the compilation cache ``cache``."""
    import subprocess

    env = dict(os.environ, JAX_PERSISTENT_CACHE_MIN_COMPILE_TIME_SECS="0")
    if cache:
        env["JAX_COMPILATION_CACHE_DIR"] = cache
    cmd = [sys.executable, str(Path(__file__).resolve()), "--probe", kind]
    t0 = time.perf_counter()
    out = subprocess.run(cmd, env=env, capture_output=True, text=True, check=True).stdout
    row = json.loads(out.strip().splitlines()[-1])
    row["process_s"] = round(time.perf_counter() - t0, 2)  # interpreter and imports included
    return row


def _bench_first_view() -> dict:
    import tempfile

    with tempfile.TemporaryDirectory() as cache:
        cold = _probe("first", cache)
        warm = _probe("first", cache)
    return {"case": "first_view", "cold": cold, "warm": warm, "target_warm_s": 1.0,
            "load_avg": [round(x, 2) for x in os.getloadavg()]}  # fmt: skip


def _run_probe(kind: str) -> None:
    import jax

    from symjax.datasets import benchmark
    from symjax.geometry import cloud_bucket
    from symjax.surface import oriented_completion, poisson_reconstruct
    from symjax.symmetry import search

    view = benchmark(["003_cracker_box/000"])[0]
    if kind == "first":
        t1 = time.perf_counter()
        r = search(view.observation)
        jax.block_until_ready(r.normal)
        t2 = time.perf_counter()
        op = oriented_completion(r, view.camera)
        poisson_reconstruct(op.points, op.normals, op.weights, table=view.observation.table)
        t3 = time.perf_counter()
        row = {"points": len(view.points), "search_s": round(t2 - t1, 3),
               "mesh_s": round(t3 - t2, 3), "first_view_s": round(t3 - t1, 3)}  # fmt: skip
        print(json.dumps(row))
        return
    import logging

    counts: dict[str, int] = {}

    class Count(logging.Handler):
        def emit(self, record):
            msg = record.getMessage()
            if msg.startswith("Compiling "):
                name = msg.split("(")[1].split(")")[0]
                counts[name] = counts.get(name, 0) + 1

    logging.getLogger("jax").addHandler(Count())
    logging.getLogger("jax").setLevel(logging.DEBUG)
    obs = view.observation
    sizes = (1500, 3000, 6000, 12000, 25000, 50000, 100000, 200000, 2500, 9000, 60000)
    buckets = sorted({cloud_bucket(n) for n in sizes})
    with jax.log_compiles(True):
        for n in sizes:
            p = obs.valid_points()
            o = _resized(obs, np.resize(p, (n, 3)) + 1e-4 * np.arange(n)[:, None] % 1e-3)
            r = search(o)
            op = oriented_completion(r, view.camera)
            poisson_reconstruct(op.points, op.normals, op.weights, table=obs.table)
    print(
        json.dumps(
            {
                "case": "compile_counts",
                "view_sizes": list(sizes),
                "point_buckets": buckets,
                "search_compiles": counts.get("_search_jit", 0),
                "poisson_compiles": counts.get("_poisson_jit", 0),
                "kernel_compiles": {k: v for k, v in counts.items() if v and k[0] == "_"},
            }
        )
    )


def _resized(obs, points):
    from symjax.observation import Observation

    return Observation.create(points, obs.camera, obs.table, obs.mask, obs.depth)


def _bench_eval_runs(preset: str) -> list[dict]:
    """``symjax eval`` cold and warm in new processes (stage totals from results.json)."""
    import subprocess
    import tempfile

    rows = []
    cache = tempfile.mkdtemp(prefix="symjax-bench-cache-")
    for tag in ("cold", "warm"):
        out = Path(tempfile.mkdtemp(prefix=f"symjax-bench-eval-{tag}-"))
        # As `make demo` runs it (the Makefile's cache settings).
        env = dict(os.environ, JAX_COMPILATION_CACHE_DIR=cache, MPLBACKEND="Agg",
                   JAX_PERSISTENT_CACHE_MIN_COMPILE_TIME_SECS="0.1")  # fmt: skip
        load0 = [round(x, 2) for x in os.getloadavg()]
        t0 = time.perf_counter()
        cmd = [sys.executable, str(ROOT / "scripts" / "eval_dataset.py"), "--out-dir", str(out),
               "--config", preset, "--execution.no-progress"]  # fmt: skip
        subprocess.run(cmd, env=env, check=True, capture_output=True)
        wall = time.perf_counter() - t0
        d = json.loads((out / "results.json").read_text())
        rows.append({
            "case": "eval_run", "cache": tag, "preset": preset, "views": d["run"]["n_views"],
            "wall_s": round(wall, 1), "target_s": 60.0, "run_s": round(d["run"]["run_s"], 1),
            "figures_s": round(d["run"]["figures_s"], 1),
            "stages_s": {k: round(v, 2) for k, v in d["summary"]["timings_s"].items()},
            "stages_ms_per_view": {k: round(1e3 * v / d["run"]["n_views"], 1)
                                   for k, v in d["summary"]["timings_s"].items()},
            "load_avg": load0, "_folder": str(out),
        })  # fmt: skip
    return rows


def _compare(before: str, after: str) -> dict:
    runs = {t: json.loads((Path(f) / "results.json").read_text())
            for t, f in (("before", before), ("after", after))}  # fmt: skip
    tb, ta = runs["before"]["summary"]["timings_s"], runs["after"]["summary"]["timings_s"]
    pb, pa = _printed(runs["before"]["summary"]), _printed(runs["after"]["summary"])
    return {
        "case": "eval_stages", "rows": len(runs["after"]["rows"]),
        "before_s": {k: round(v, 2) for k, v in tb.items()},
        "after_s": {k: round(v, 2) for k, v in ta.items()},
        "ratio": {k: round(tb[k] / ta[k], 2) for k in tb if k in ta and ta[k] > 0},
        "run_before_s": round(runs["before"]["run"]["run_s"], 1),
        "run_after_s": round(runs["after"]["run"]["run_s"], 1),
        # report.md up to its timings: every number the report prints of the results
        "report_unchanged": len({(Path(f) / "report.md").read_text().split("## Timings")[0]
                                 for f in (before, after)}) == 1,
        "summary_unchanged_to_3_digits": json.dumps(pb) == json.dumps(pa),
        "methods_unchanged_to_3_digits": pb["methods"] == pa["methods"],
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
