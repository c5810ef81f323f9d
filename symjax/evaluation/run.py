"""The batched evaluation loop of the paper's Section V-A/V-B, resumable view by view.

For each batch of views: one jitted symmetry search over the batch, oriented normals of each
completed cloud, one jitted Poisson solve per depth over the batch (marching cubes on the host),
the Delaunay baseline per view, then the metrics against the ground truth. Each view's results
are written atomically to ``<out>/views/<dataset>__<deg>.json`` as soon as its batch is done, so
an interrupted run resumes where it stopped: views whose file holds the same configuration key
(:meth:`EvalConfig.key`) are skipped.

Batch stage times (search, Poisson solve) are shared equally among the views of the batch.
"""

from __future__ import annotations

import json
import math
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from symjax._atomic import atomic_write_json
from symjax.errors import InvalidInputError, MissingFileError, SymjaxError
from symjax.evaluation.config import POISSON_DEPTHS, EvalConfig, parse_subset

__all__ = [
    "ROW_FIELDS",
    "evaluate",
    "load_records",
    "rows_of",
    "run_evaluation",
    "select_views",
    "view_file",
]

#: Columns of ``results.csv``, one row per view and method. Lengths in mm, variance in mm^2,
#: centroid error as a fraction of the ground truth's oriented-box diagonal, times in seconds.
ROW_FIELDS = (
    "view",
    "dataset",
    "object",
    "orientation_deg",
    "method",
    "ok",
    "error",
    "dev_mean_mm",
    "dev_var_mm2",
    "dev_max_mm",
    "dev_p50_mm",
    "dev_p95_mm",
    "centroid_error",
    "plane_error_deg",
    "plane_error_mm",
    "n_points",
    "n_faces",
    "build_s",
    "metric_s",
)

NAN = float("nan")


def view_file(out_dir: str | Path, name: str) -> Path:
    """Per-view result file: ``<out>/views/<dataset>__<deg>.json``."""
    return Path(out_dir) / "views" / (name.replace("/", "__") + ".json")


# ---------------------------------------------------------------------------------------------
# View selection


class _KthViews(Sequence):
    """The views of a KTH-layout folder as a sequence with names (loaded up front)."""

    def __init__(self, views: list):
        self._views = views
        self.names = [v.name for v in views]

    def __len__(self) -> int:
        return len(self._views)

    def __getitem__(self, i):
        return self._views[i]


def _filter_names(names: list[str], subset: tuple[str, ...], datasets: set[str]) -> list[int]:
    """Indices of ``names`` kept by the subset items (see :func:`parse_subset`)."""
    spec = parse_subset(subset)
    keep = list(range(len(names)))
    if spec["names"]:
        wanted = set(spec["names"])
        unknown = sorted(wanted - datasets - set(names))
        if unknown:
            raise InvalidInputError(
                f"unknown data set or view {unknown[0]!r} in --subset; known data sets: "
                + ", ".join(sorted(datasets))
            )
        keep = [i for i in keep if names[i] in wanted or names[i].split("/")[0] in wanted]
    if spec["orientations"]:
        degs = spec["orientations"]

        def deg_of(n: str) -> float:
            tail = n.rsplit("/", 1)[-1]
            return float(tail) if tail.isdigit() else NAN

        keep = [i for i in keep if any(abs(deg_of(names[i]) - d) < 1e-6 for d in degs)]
    if spec["first"] is not None:
        keep = keep[: spec["first"]]
    if not keep:
        raise InvalidInputError(f"--subset {','.join(subset)} selects no view")
    return keep


def select_views(cfg: EvalConfig) -> Sequence:
    """The views to evaluate: the embedded benchmark or a KTH-layout folder, subset applied.

    Returns:
        A sequence of :class:`~symjax.datasets.View` with a ``names`` attribute (benchmark
        views are loaded lazily, generated into the cache on first use).

    Raises:
        MissingFileError: ``cfg.data`` is not a folder or holds no view.
        FileFormatError: A file of ``cfg.data`` is corrupt.
        InvalidInputError: The subset names an unknown data set or selects nothing.
    """
    if cfg.data is not None:
        from symjax.datasets import View
        from symjax.io import load_kth_directory

        root = Path(cfg.data).expanduser()
        if not root.is_dir():
            raise MissingFileError(f"--data folder {str(root)!r} does not exist")
        views = [View.from_kth(k) for k in load_kth_directory(root)]
        names = [v.name for v in views]
        if len(set(names)) != len(names):
            raise InvalidInputError(f"--data folder {str(root)!r} holds views with equal names")
        keep = _filter_names(names, cfg.subset, {v.dataset for v in views})
        return _KthViews([views[i] for i in keep])

    from symjax.datasets import DATASET_IDS, benchmark
    from symjax.datasets.benchmark import view_names

    names = view_names()
    keep = _filter_names(names, cfg.subset, set(DATASET_IDS))
    return benchmark([names[i] for i in keep], cache_dir=cfg.cache_dir, seed=cfg.seed)


# ---------------------------------------------------------------------------------------------
# Per-view stages


def _err(e: BaseException) -> str:
    return f"{type(e).__name__}: {e}".splitlines()[0][:300]


def _deviation_mesh(mesh):
    """The mesh to measure distances to: large triangles split, the same surface.

    ``symjax.metrics.surface_distance`` bounds its candidate search by the largest triangle of
    the mesh; the Delaunay baseline's long side walls (front contour to back sheet) make that
    bound cover the whole mesh and the query ~30x slower. Midpoint subdivision keeps the surface
    exactly, so the distances are unchanged.
    """
    import trimesh

    edges = np.linalg.norm(np.diff(mesh.vertices[mesh.edges_unique], axis=1)[:, 0], axis=1)
    limit = 4.0 * float(np.median(edges))
    if float(edges.max()) <= limit:
        return mesh
    v, f = trimesh.remesh.subdivide_to_size(mesh.vertices, mesh.faces, max_edge=limit, max_iter=12)
    return trimesh.Trimesh(v, f, process=False)


def _measure(view, mesh, cfg: EvalConfig) -> dict[str, Any]:
    """Deviation statistics (mm) and centroid error of one mesh against the view's truth."""
    from symjax.metrics import centroid_error, mesh_deviation

    out = {
        "dev_mean_mm": NAN,
        "dev_var_mm2": NAN,
        "dev_max_mm": NAN,
        "dev_p50_mm": NAN,
        "dev_p95_mm": NAN,
        "centroid_error": NAN,
    }
    if view.gt_mesh is None:
        return out
    dev = mesh_deviation(view.gt_mesh, _deviation_mesh(mesh), n_samples=cfg.n_samples)
    out.update(
        dev_mean_mm=1e3 * dev.mean,
        dev_var_mm2=1e6 * dev.variance,
        dev_max_mm=1e3 * dev.max,
        dev_p50_mm=1e3 * dev.percentiles[50],
        dev_p95_mm=1e3 * dev.percentiles[95],
        centroid_error=centroid_error(view.gt_mesh, mesh, n_samples=cfg.n_samples),
    )
    return out


def _plane_record(view, res) -> dict[str, Any]:
    """The found plane and, where the truth is known, its error (deg, mm)."""
    from symjax.datasets import plane_error

    normal = np.asarray(res.normal, np.float64)
    rec = {
        "normal": [float(x) for x in normal],
        "offset_m": float(res.offset),
        "vote": float(res.vote),
        "plane_error_deg": NAN,
        "plane_error_mm": NAN,
        "n_mirrored": int(np.sum(np.asarray(res.mirrored_keep))),
    }
    known = view.symmetry in ("planar", "rotational") and (
        view.symmetry_planes is not None or view.symmetry_axis is not None
    )
    if known:
        try:
            deg, m = plane_error(view, normal, float(res.offset))
            rec["plane_error_deg"], rec["plane_error_mm"] = float(deg), 1e3 * float(m)
        except SymjaxError:
            pass
    return rec


def _poisson_batch(ops: list, depth: int, cfg: EvalConfig) -> tuple[list, list[str | None], float]:
    """Meshes of a batch of oriented clouds at one depth: one jitted solve, per-view checks.

    A view that fails validation or meshing gets ``None`` and its error message; the others
    still go through the batched solve.

    Returns:
        ``(meshes, errors, solve_seconds)``; meshes per view (None where it failed).
    """
    import jax

    from symjax.surface import PoissonConfig, grid_to_mesh, pack_views, poisson_grids

    pcfg = PoissonConfig(depth=depth)
    n = len(ops)
    meshes: list = [None] * n
    errors: list[str | None] = ["no completed cloud" if op is None else None for op in ops]
    good = [i for i in range(n) if ops[i] is not None]
    if not good:
        return meshes, errors, 0.0
    # A power-of-two point count keeps the compiled solver across batches.
    n_pad = 1 << int(math.ceil(math.log2(max(len(ops[i]) for i in good))))
    packed: dict[int, tuple] = {}
    for i in good:
        try:
            packed[i] = pack_views([(ops[i].points, ops[i].normals, ops[i].weights)], n_pad, pcfg)
        except SymjaxError as e:
            errors[i] = _err(e)
    idx = sorted(packed)
    if not idx:
        return meshes, errors, 0.0
    t0 = time.perf_counter()
    arrays = [np.concatenate([packed[i][k] for i in idx]) for k in range(4)]
    grids = jax.device_get(poisson_grids(*arrays, pcfg))
    solve = time.perf_counter() - t0
    for j, i in enumerate(idx):
        try:
            meshes[i] = grid_to_mesh(grids[j], pcfg)
        except SymjaxError as e:
            errors[i] = _err(e)
    return meshes, errors, solve


def _search(observations: list, cfg: EvalConfig) -> list:
    """Single-view symmetry results of a batch; per view on a batch failure (None where bad)."""
    from symjax.symmetry import search_batch

    try:
        res = search_batch(observations, cfg.symmetry)
        return [res[i] for i in range(len(observations))]
    except SymjaxError:
        # One bad view must not sink the batch: find it by searching one by one.
        out = []
        for o in observations:
            try:
                out.append(search_batch([o], cfg.symmetry)[0])
            except SymjaxError:
                out.append(None)
        return out


def _process_batch(views: list, cfg: EvalConfig, load_s: list[float]) -> list[dict[str, Any]]:
    """Runs every stage on one batch of views; returns their records."""
    import jax

    from symjax.surface import delaunay_mesh, oriented_completion

    n = len(views)
    mir = [m for m in cfg.methods if m in POISSON_DEPTHS]
    timings: list[dict[str, float]] = [{"load": load_s[i]} for i in range(n)]
    results: list = [None] * n
    ops: list = [None] * n
    op_errors: list[str | None] = [None] * n
    if mir:
        t0 = time.perf_counter()
        results = _search([v.observation for v in views], cfg)
        jax.block_until_ready([r.normal for r in results if r is not None])
        share = (time.perf_counter() - t0) / n
        for i in range(n):
            timings[i]["symmetry"] = share
            if results[i] is None:
                op_errors[i] = "symmetry search failed"
                continue
            t1 = time.perf_counter()
            try:
                ops[i] = oriented_completion(results[i], views[i].camera, cfg.normals)
            except SymjaxError as e:
                op_errors[i] = _err(e)
            timings[i]["normals"] = time.perf_counter() - t1

    meshes: dict[str, list] = {}
    errors: dict[str, list] = {}
    for m in mir:
        t0 = time.perf_counter()
        meshes[m], errors[m], solve = _poisson_batch(ops, POISSON_DEPTHS[m], cfg)
        per_view_host = (time.perf_counter() - t0 - solve) / n
        for i in range(n):
            timings[i][f"poisson{POISSON_DEPTHS[m]}"] = solve / n + per_view_host
            if op_errors[i] is not None:
                errors[m][i] = op_errors[i]
    if "Del" in cfg.methods:
        meshes["Del"], errors["Del"] = [None] * n, [None] * n
        for i, v in enumerate(views):
            t1 = time.perf_counter()
            try:
                meshes["Del"][i] = delaunay_mesh(v.points, v.camera, cfg.delaunay)
            except SymjaxError as e:
                errors["Del"][i] = _err(e)
            timings[i]["delaunay"] = time.perf_counter() - t1

    records = []
    for i, v in enumerate(views):
        methods = {}
        for m in cfg.methods:
            mesh = meshes[m][i]
            rec: dict[str, Any] = {"ok": mesh is not None, "error": errors[m][i], "n_faces": 0}
            t1 = time.perf_counter()
            if mesh is not None:
                rec["n_faces"] = int(len(mesh.faces))
                try:
                    rec.update(_measure(v, mesh, cfg))
                except SymjaxError as e:
                    rec.update(ok=False, error=_err(e))
            timings[i][f"metrics_{m}"] = time.perf_counter() - t1
            methods[m] = rec
        records.append(
            {
                "view": v.name,
                "dataset": v.dataset,
                "object": v.object_name,
                "orientation_deg": float(v.orientation_deg),
                "source": v.source,
                "has_ground_truth": v.gt_mesh is not None,
                "config_key": cfg.key(),
                "n_points": int(len(v.points)),
                "symmetry": None if results[i] is None else _plane_record(v, results[i]),
                "methods": methods,
                "timings_s": timings[i],
            }
        )
    return records


# ---------------------------------------------------------------------------------------------
# Driver


def load_records(cfg: EvalConfig, names: Sequence[str]) -> dict[str, dict[str, Any]]:
    """Per-view records already written with the same configuration and all methods."""
    done = {}
    key = cfg.key()
    for name in names:
        path = view_file(cfg.out_dir, name)
        if not path.is_file():
            continue
        try:
            rec = json.loads(path.read_text())
        except (OSError, ValueError):
            continue  # a damaged file is recomputed, not trusted
        if rec.get("config_key") == key and all(m in rec.get("methods", {}) for m in cfg.methods):
            done[name] = rec
    return done


def evaluate(
    cfg: EvalConfig, log: Callable[[str], None] = print
) -> tuple[list[dict[str, Any]], dict[str, Any]]:
    """Evaluates the selected views, resuming from results already written.

    Args:
        cfg: Evaluation configuration.
        log: Where progress messages go.

    Returns:
        ``(records, info)``: one record per selected view (in view order; resumed ones read
        back from disk), and run information (``n_views``, ``n_resumed``, ``n_computed``,
        ``select_s`` (view selection and benchmark generation), ``run_s``).
    """
    from tqdm import tqdm

    t_start = time.perf_counter()
    views = select_views(cfg)
    names = list(views.names)
    select_s = time.perf_counter() - t_start
    done = load_records(cfg, names) if cfg.resume else {}
    todo = [i for i, n in enumerate(names) if n not in done]
    log(
        f"{len(names)} views: {len(done)} already done in {cfg.out_dir}, {len(todo)} to evaluate"
        f" ({', '.join(cfg.methods)}; batches of {cfg.batch_size})"
    )
    bar = tqdm(total=len(todo), unit="view", disable=not cfg.progress or not todo, leave=False)
    try:
        for s in range(0, len(todo), cfg.batch_size):
            batch, load_s = [], []
            for i in todo[s : s + cfg.batch_size]:
                t0 = time.perf_counter()
                batch.append(views[i])
                load_s.append(time.perf_counter() - t0)
            for rec in _process_batch(batch, cfg, load_s):
                atomic_write_json(view_file(cfg.out_dir, rec["view"]), _jsonable(rec))
                done[rec["view"]] = rec
            bar.update(len(batch))
    finally:
        bar.close()
    records = [done[n] for n in names]
    info = {
        "n_views": len(names),
        "n_resumed": len(names) - len(todo),
        "n_computed": len(todo),
        "select_s": select_s,
        "run_s": time.perf_counter() - t_start,
    }
    return records, info


def _jsonable(obj: Any) -> Any:
    """NaN becomes null in the JSON files (strict JSON); read back as NaN by :func:`rows_of`."""
    if isinstance(obj, float):
        return obj if math.isfinite(obj) else None
    if isinstance(obj, dict):
        return {k: _jsonable(v) for k, v in obj.items()}
    if isinstance(obj, list | tuple):
        return [_jsonable(v) for v in obj]
    return obj


def _num(x: Any) -> float:
    return NAN if x is None else float(x)


def rows_of(records: list[dict[str, Any]], methods: Sequence[str]) -> list[dict[str, Any]]:
    """Flattens records into one row per view and method (columns :data:`ROW_FIELDS`)."""
    rows = []
    for rec in records:
        sym = rec.get("symmetry") or {}
        t = rec.get("timings_s", {})
        for m in methods:
            r = rec["methods"][m]
            if m in POISSON_DEPTHS:
                build = sum(_num(t.get(k, 0.0)) for k in ("symmetry", "normals"))
                build += _num(t.get(f"poisson{POISSON_DEPTHS[m]}", 0.0))
            else:
                build = _num(t.get("delaunay", 0.0))
            rows.append(
                {
                    "view": rec["view"],
                    "dataset": rec["dataset"],
                    "object": rec["object"],
                    "orientation_deg": _num(rec["orientation_deg"]),
                    "method": m,
                    "ok": bool(r["ok"]),
                    "error": r.get("error") or "",
                    "dev_mean_mm": _num(r.get("dev_mean_mm")),
                    "dev_var_mm2": _num(r.get("dev_var_mm2")),
                    "dev_max_mm": _num(r.get("dev_max_mm")),
                    "dev_p50_mm": _num(r.get("dev_p50_mm")),
                    "dev_p95_mm": _num(r.get("dev_p95_mm")),
                    "centroid_error": _num(r.get("centroid_error")),
                    "plane_error_deg": _num(sym.get("plane_error_deg")),
                    "plane_error_mm": _num(sym.get("plane_error_mm")),
                    "n_points": int(rec["n_points"]),
                    "n_faces": int(r.get("n_faces", 0)),
                    "build_s": build,
                    "metric_s": _num(t.get(f"metrics_{m}", 0.0)),
                }
            )
    return rows


def run_evaluation(cfg: EvalConfig, log: Callable[[str], None] = print) -> dict[str, Any]:
    """Evaluates, then writes the tables, the figures and ``report.md`` under ``cfg.out_dir``.

    Args:
        cfg: Evaluation configuration.
        log: Where progress messages go.

    Returns:
        ``{"summary", "info", "files"}``: the summary numbers, run information (as
        :func:`evaluate`, plus ``figures_s`` and ``total_s``) and the written paths by name.

    Raises:
        SymjaxError: On a bad configuration or a missing or malformed data folder.
    """
    from symjax.evaluation import figures as F
    from symjax.evaluation.report import summarize, write_report, write_tables

    t_start = time.perf_counter()
    records, info = evaluate(cfg, log)
    rows = rows_of(records, cfg.methods)
    summary = summarize(records, rows, cfg.methods)
    out = Path(cfg.out_dir)
    t0 = time.perf_counter()
    figs: dict[str, str] = {}
    if any(r["has_ground_truth"] for r in records):
        F.plot_deviation(rows, cfg.methods, "orientation_deg", out / "fig10_orientation.png")
        figs["Fig. 10: deviation per orientation"] = "fig10_orientation.png"
        F.plot_deviation(rows, cfg.methods, "dataset", out / "fig11_objects.png")
        figs["Fig. 11: deviation per object"] = "fig11_objects.png"
        F.plot_centroid(rows, cfg.methods, out / "fig12_centroid.png")
        figs["Fig. 12: centroid error per orientation"] = "fig12_centroid.png"
    picks = F.pick_gallery(records, cfg.gallery)
    if picks:
        views = select_views(cfg)
        by_name = {n: i for i, n in enumerate(views.names)}
        F.gallery(
            [views[by_name[n]] for n, _ in picks],
            [c for _, c in picks],
            cfg,
            out / "gallery.png",
        )
        figs["Gallery: partial cloud, mirrored cloud, Mir7 mesh"] = "gallery.png"
    info["figures_s"] = time.perf_counter() - t0
    info["total_s"] = time.perf_counter() - t_start
    source = f"KTH-layout folder {cfg.data}" if cfg.data else "embedded benchmark"
    p_csv, p_json = write_tables(out, rows, summary, cfg.to_json(), info)
    report = write_report(out, summary, cfg.methods, figs, info, source)
    files = {"report": report, "csv": p_csv, "json": p_json}
    files.update({Path(v).stem: out / v for v in figs.values()})
    return {"summary": summary, "info": info, "files": files}
