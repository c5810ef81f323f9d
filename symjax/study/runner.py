"""The study over many views: the completions of a batch of views in one symmetry search and one
Poisson solve, then each view's plans and rollouts; one JSON file per view, written atomically,
so a rerun with the same settings resumes."""

from __future__ import annotations

import json
import re
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from symjax._atomic import atomic_write_json
from symjax.errors import FileFormatError, SymjaxError, one_line
from symjax.study.config import StudyConfig
from symjax.study.protocol import study_view

__all__ = ["planning_meshes", "run_study", "study_views"]


def study_views(cfg: StudyConfig) -> list[tuple[str, Callable[[], Any]]]:
    """``(name, load)`` per view: the benchmark's (or its subset's), then the extra scans' (those
    not in the benchmark already)."""
    from symjax.datasets import benchmark, load_object, render_view

    bench = benchmark(list(cfg.subset) or None, cache_dir=cfg.cache_dir, seed=cfg.seed)
    out = [(n, (lambda i=i: bench[i])) for i, n in enumerate(bench.names)]
    have = {n.split("/")[0] for n in bench.names}
    for scan in (s for s in cfg.extra_scans if s not in have):  # a benchmark scan once
        for deg in cfg.extra_orientations:
            out.append(
                (
                    f"{scan}/{int(deg):03d}",
                    lambda s=scan, d=deg: render_view(load_object(s), d, cfg.seed),
                )
            )
    return out


def planning_meshes(views: list, cfg: StudyConfig) -> list[dict[str, Any]]:
    """``{"C": mesh or error text, "K": ShapeSet or error text, "P": ...}`` per view: C by one
    batched search and Poisson solve (cut at each view's table), K its plausible shapes
    (:func:`~symjax.completion.plausible_shapes`, C first; only with ``completion.shapes`` > 1),
    P the Delaunay baseline cut there (the grasp cycle's
    :func:`~symjax.cycle.shapes.completed_meshes` and
    :func:`~symjax.cycle.shapes.baseline_meshes`)."""
    from symjax.completion import plausible_shapes
    from symjax.cycle.shapes import baseline_meshes, completed_meshes

    obs = [v.observation for v in views]
    tables = [o.table for o in obs]

    def kept(m):
        return one_line(m, 240) if isinstance(m, SymjaxError) else m

    base = baseline_meshes(obs, tables, cfg)
    if cfg.completion.shapes == 1:
        return [{"C": kept(c), "P": kept(p)}
                for c, p in zip(completed_meshes(obs, tables, cfg), base, strict=True)]  # fmt: skip
    # The shapes' first is the view's completion, meshed as completed_meshes meshes it (a view's
    # Poisson mesh does not depend on the batch).
    out = []
    for k, p in zip(plausible_shapes(obs, cfg), base, strict=True):
        c = k if isinstance(k, SymjaxError) else k.meshes[0]
        out.append({"C": kept(c), "K": kept(k), "P": kept(p)})
    return out


def _file(out: Path, name: str) -> Path:
    return out / "views" / (re.sub(r"[^A-Za-z0-9_.-]", "_", name) + ".json")


def run_study(cfg: StudyConfig, log: Callable[[str], None] = print) -> list[dict[str, Any]]:
    """Runs (or resumes) the study; returns every view's record, in view order."""
    out = Path(cfg.out_dir)
    if out.exists() and not out.is_dir():
        raise FileFormatError(f"out_dir {str(out)!r} is a file; expected a folder")
    key = cfg.key()
    views = study_views(cfg)
    done: dict[str, dict] = {}
    for name, _ in views:
        p = _file(out, name)
        if p.is_file():
            try:
                d = json.loads(p.read_text())
            except (OSError, json.JSONDecodeError):
                continue  # a damaged file is redone
            if d.get("key") == key:
                done[name] = d
    todo = [(n, load) for n, load in views if n not in done]
    log(f"{len(views)} views: {len(done)} already done in {out}, {len(todo)} to run")
    for s in range(0, len(todo), cfg.batch):
        t0 = time.perf_counter()
        chunk = [(n, load()) for n, load in todo[s : s + cfg.batch]]
        meshes = planning_meshes([v for _, v in chunk], cfg)
        share = (time.perf_counter() - t0) / len(chunk)
        for (name, view), m in zip(chunk, meshes, strict=True):
            try:
                rec = study_view(view, m, cfg)
            except SymjaxError as e:
                rec = {"view": name, "error": one_line(e, 240), "hands": {}}
            rec.update(key=key, view=name, completion_seconds=round(share, 3))
            atomic_write_json(_file(out, name), rec)
            done[name] = rec
        log(f"{min(s + cfg.batch, len(todo))}/{len(todo)} views ({time.perf_counter() - t0:.0f} s)")
    return [done[n] for n, _ in views]
