"""The evaluation's stages on one batch of views (paper Section V-A/V-B).

One jitted symmetry search over the batch, oriented normals of each completed cloud, one jitted
Poisson solve per depth over the batch (marching cubes on the host), the Delaunay baseline per
view, then the metrics against the ground truth. A view that fails a stage gets its error in its
record; the other views of the batch go on. Batch stage times (search, Poisson solve) are shared
equally among the views of the batch.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

import numpy as np

from symjax import _interrupt
from symjax.errors import SymjaxError, one_line
from symjax.evaluation.config import POISSON_DEPTHS, EvalConfig
from symjax.evaluation.metric_jobs import MetricRunner
from symjax.evaluation.records import MeshResult, PlaneResult, ViewRecord

__all__ = ["poisson_meshes", "start_batch"]


def _plane_result(view, res, completion) -> PlaneResult:
    """The found plane, the completion chosen and, where the truth is known, the plane's error
    (deg, mm)."""
    from symjax.datasets import symmetry_truth
    from symjax.metrics import plane_error

    normal = np.asarray(res.normal, np.float64)
    deg = mm = float("nan")
    known = view.symmetry in ("planar", "rotational") and (
        view.symmetry_planes is not None or view.symmetry_axis is not None
    )
    if known:
        try:
            deg, m = plane_error(normal, float(res.offset), **symmetry_truth(view))
            mm = 1e3 * m
        except SymjaxError:
            pass
    return PlaneResult(
        normal=tuple(float(x) for x in normal),
        offset_m=float(res.offset),
        vote=float(res.vote),
        plane_error_deg=float(deg),
        plane_error_mm=float(mm),
        n_mirrored=int(np.sum(np.asarray(res.mirrored_keep))),
        **(
            {}
            if completion is None
            else dict(
                support=completion.support,
                rival_support=completion.rival_support,
                confidence=completion.confidence,
                completion=completion.kind,
                completion_reason=completion.reason,
                revolution_residual=completion.revolution.residual,
            )
        ),
    )


def _search(observations: list, cfg: EvalConfig) -> list:
    """Single-view symmetry results of a batch (None where a view could not be searched)."""
    from symjax.symmetry import search_batch

    try:
        res = search_batch(observations, cfg.symmetry, cfg.execution)
    except SymjaxError:  # no view of the batch could be searched
        return [None] * len(observations)
    return [res[i] if ok else None for i, ok in enumerate(res.ok)]


def poisson_meshes(ops: list, depth: int, cfg: EvalConfig, tables: list) -> list:
    """Meshes (or error messages) of a batch of oriented clouds at one depth, each cut at its
    view's table (an object stands on it: nothing of it is below)."""
    import dataclasses

    from symjax.surface import poisson_reconstruct_batch

    pcfg = dataclasses.replace(cfg.poisson, depth=depth)
    out: list = ["no completed cloud" if op is None else None for op in ops]
    # A completion that is a mesh already (the fallback hull) is its own Mir5 and Mir7.
    for i, op in enumerate(ops):
        if op is not None and not hasattr(op, "normals"):
            out[i] = op
    good = [i for i, op in enumerate(ops) if op is not None and hasattr(op, "normals")]
    if good:
        meshes = poisson_reconstruct_batch(
            [ops[i] for i in good],
            pcfg,
            cfg.execution,
            errors="keep",
            tables=[tables[i] for i in good],
        )
        for i, m in zip(good, meshes, strict=True):
            out[i] = one_line(m) if isinstance(m, SymjaxError) else m
    return out


def start_batch(
    views: list, config: EvalConfig, load_s: list[float], runner: MetricRunner
) -> Callable[[], list[ViewRecord]]:
    """Runs the stages of one batch up to the meshes and hands their metrics to ``runner``.

    Returns:
        A function that waits for the metrics and returns the batch's records.
    """
    import jax

    from symjax.completion import choose_completion
    from symjax.surface import delaunay_mesh

    n = len(views)
    mir = [m for m in config.methods if m in POISSON_DEPTHS]
    timings: list[dict[str, float]] = [{"load": load_s[i]} for i in range(n)]
    results: list = [None] * n
    ops: list = [None] * n  # oriented points to mesh, or the fallback's mesh
    chosen: list = [None] * n
    op_errors: list[str | None] = [None] * n
    if mir:
        t0 = time.perf_counter()
        results = _search([v.observation for v in views], config)
        jax.block_until_ready([r.normal for r in results if r is not None])
        share = (time.perf_counter() - t0) / n
        for i in range(n):
            _interrupt.check()
            timings[i]["symmetry"] = share
            if results[i] is None:
                op_errors[i] = "symmetry search failed"
                continue
            t1 = time.perf_counter()
            try:
                c = choose_completion(
                    results[i],
                    views[i].observation,
                    config.completion,
                    config.normals,
                    config.symmetry,
                )
                chosen[i] = c
                ops[i] = c.oriented if c.mesh is None else c.mesh
            except SymjaxError as e:
                op_errors[i] = one_line(e)
            timings[i]["normals"] = time.perf_counter() - t1

    built: dict[str, list] = {}  # method -> per view: a mesh or an error message
    for m in mir:
        t0 = time.perf_counter()
        built[m] = poisson_meshes(
            ops, POISSON_DEPTHS[m], config, [v.observation.table for v in views]
        )
        share = (time.perf_counter() - t0) / n
        for i in range(n):
            timings[i][f"poisson{POISSON_DEPTHS[m]}"] = share
            if op_errors[i] is not None:
                built[m][i] = op_errors[i]
    if "Del" in config.methods:
        built["Del"] = [None] * n
        for i, v in enumerate(views):
            _interrupt.check()
            t1 = time.perf_counter()
            try:
                built["Del"][i] = delaunay_mesh(v.points, v.camera, config.delaunay)
            except SymjaxError as e:
                built["Del"][i] = one_line(e)
            timings[i]["delaunay"] = time.perf_counter() - t1

    jobs: dict[tuple[int, str], Any] = {}
    for i, v in enumerate(views):
        for m in config.methods:
            if not isinstance(built[m][i], str):
                jobs[i, m] = runner.submit(
                    m, v.gt_mesh, built[m][i], config.n_samples, v.gt_diagonal
                )

    def finish() -> list[ViewRecord]:
        records = []
        key = config.key()
        for i, v in enumerate(views):
            _interrupt.check()
            per_method: list[MeshResult] = []
            for m in config.methods:
                if (i, m) in jobs:
                    res, timings[i][f"metrics_{m}"] = jobs[i, m].result()
                else:
                    res, timings[i][f"metrics_{m}"] = MeshResult(m, False, error=built[m][i]), 0.0
                per_method.append(res)
            records.append(
                ViewRecord(
                    view=v.name,
                    dataset=v.dataset,
                    object=v.object_name,
                    orientation_deg=float(v.orientation_deg),
                    source=v.source,
                    has_ground_truth=v.gt_mesh is not None,
                    config_key=key,
                    n_points=int(len(v.points)),
                    symmetry=(
                        None if results[i] is None else _plane_result(v, results[i], chosen[i])
                    ),
                    results=tuple(per_method),
                    timings_s=timings[i],
                )
            )
        return records

    return finish
