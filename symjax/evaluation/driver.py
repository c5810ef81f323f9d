"""The paper's evaluation (Section V-A/V-B) as a resumable job: batches of views through
:mod:`symjax.evaluation.stages`, records written as each batch finishes, then the tables,
figures and report.

An interrupted run resumes where it stopped: views whose file holds a record with the same
configuration key (:meth:`EvalConfig.key`, the numbers alone) are skipped.
"""

from __future__ import annotations

import json
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from symjax import _interrupt
from symjax._atomic import atomic_write_json
from symjax.errors import ConfigError, InvalidInputError
from symjax.evaluation.config import EvalConfig
from symjax.evaluation.metric_jobs import MetricRunner
from symjax.evaluation.records import ViewRecord, load_records, rows_of, view_file
from symjax.evaluation.selection import select_views
from symjax.evaluation.stages import start_batch
from symjax.geometry import cloud_bucket

__all__ = ["claim_folder", "evaluate", "run_evaluation", "writable_folder"]


def writable_folder(path: str | Path) -> Path:
    """Creates ``path`` and checks that files can be written there, before any work starts.

    Raises:
        InvalidInputError: It cannot be created or written (a file in the way, no permission).
    """
    p = Path(path)
    try:
        p.mkdir(parents=True, exist_ok=True)
        probe = p / ".symjax-write-test"
        probe.write_bytes(b"")
        probe.unlink()
    except OSError as e:
        raise InvalidInputError(
            f"cannot write to the output folder {str(p)!r} ({e.strerror or e}); expected a"
            " folder that can be created and written"
        ) from None
    return p


def claim_folder(cfg: EvalConfig, names: list[str]) -> None:
    """Refuses an output folder that holds another run's results.

    ``run.json`` records the numbers' key, the methods and the views. A run with the same ones
    resumes; any other would rewrite the tables for a different selection or mix results of
    other settings, so it stops with a message instead.

    Raises:
        ConfigError: The folder belongs to a run of other settings or another view selection.
    """
    path = Path(cfg.out_dir) / "run.json"
    mine = {"config_key": cfg.key(), "methods": list(cfg.methods), "views": names}
    if path.is_file():
        try:
            theirs = json.loads(path.read_text())
        except (OSError, ValueError):
            theirs = None  # a damaged claim is replaced
        if isinstance(theirs, dict) and theirs != mine:
            what = (
                "other settings (config key {} here, {} in the folder)".format(
                    mine["config_key"], theirs.get("config_key")
                )
                if theirs.get("config_key") != mine["config_key"]
                else "another selection of views or methods ({} views, {} here)".format(
                    len(theirs.get("views", [])), len(names)
                )
            )
            raise ConfigError(
                f"{cfg.out_dir} holds the results of a run with {what}; use another --out-dir,"
                " or the same settings to resume"
            )
    atomic_write_json(path, mine)


def _by_bucket(views, todo: list[int]) -> list[int]:
    """``todo`` ordered by point bucket, so that a batch shares one jitted call.

    A view's numbers do not depend on the rest of its batch, so the order changes no result.
    """

    def size(i: int) -> int:
        n = views.n_points(i) if hasattr(views, "n_points") else len(views[i].points)
        return cloud_bucket(n)

    return sorted(todo, key=lambda i: (size(i), i))


def evaluate(
    config: EvalConfig, log: Callable[[str], None] = print
) -> tuple[list[ViewRecord], dict[str, Any]]:
    """Evaluates the selected views, resuming from results already written.

    Args:
        config: Evaluation configuration.
        log: Where progress messages go.

    Returns:
        ``(records, info)``: one :class:`ViewRecord` per selected view (in view order; resumed
        ones read back from disk), and run information (``n_views``, ``n_resumed``,
        ``n_computed``, ``select_s`` (view selection and benchmark generation), ``run_s``).
    """
    from tqdm import tqdm

    ex = config.execution
    t_start = time.perf_counter()
    writable_folder(config.out_dir)
    views = select_views(config)
    names = list(views.names)
    select_s = time.perf_counter() - t_start
    claim_folder(config, names)
    key = config.key()
    done = load_records(config.out_dir, names, key, config.methods, log) if config.resume else {}
    todo = _by_bucket(views, [i for i, n in enumerate(names) if n not in done])
    log(
        f"{len(names)} views: {len(done)} already done in {config.out_dir}, {len(todo)} to evaluate"
        f" ({', '.join(config.methods)}; batches of {ex.eval_batch_size})"
    )
    bar = tqdm(total=len(todo), unit="view", disable=not ex.progress or not todo, leave=False)

    def write(records: list[ViewRecord]) -> None:
        for rec in records:
            atomic_write_json(view_file(config.out_dir, rec.view), rec.to_json())
            done[rec.view] = rec
        bar.update(len(records))

    # The metrics of a batch are measured in workers while the next batch is searched and
    # meshed. A run of one batch gains nothing from one worker it would have to start, but
    # several measure its meshes side by side (a many-core GPU machine's single batch).
    several = len(todo) > ex.eval_batch_size or (ex.metric_workers > 1 and len(todo) > 1)
    workers = ex.metric_workers if several else 0
    try:
        with MetricRunner(workers) as runner:
            pending = None
            for s in range(0, len(todo), ex.eval_batch_size):
                batch, load_s = [], []
                for i in todo[s : s + ex.eval_batch_size]:
                    _interrupt.check()
                    t0 = time.perf_counter()
                    batch.append(views[i])
                    load_s.append(time.perf_counter() - t0)
                finish = start_batch(batch, config, load_s, runner)
                if pending is not None:
                    write(pending())
                pending = finish
            if pending is not None:
                write(pending())
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


def run_evaluation(config: EvalConfig, log: Callable[[str], None] = print) -> dict[str, Any]:
    """Evaluates, then writes the tables, the figures and ``report.md`` under ``config.out_dir``.

    Args:
        config: Evaluation configuration.
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
    records, info = evaluate(config, log)
    rows = rows_of(records, config.methods)
    summary = summarize(records, rows, config.methods)
    out = Path(config.out_dir)
    t0 = time.perf_counter()
    figs: dict[str, str] = {}
    if any(r.has_ground_truth for r in records):
        F.plot_deviation(rows, config.methods, "orientation_deg", out / "fig10_orientation.png")
        figs["Fig. 10: deviation per orientation"] = "fig10_orientation.png"
        F.plot_deviation(rows, config.methods, "dataset", out / "fig11_objects.png")
        figs["Fig. 11: deviation per object"] = "fig11_objects.png"
        F.plot_centroid(rows, config.methods, out / "fig12_centroid.png")
        figs["Fig. 12: centroid error per orientation"] = "fig12_centroid.png"
        if F.plot_confidence(records, out / "fig13_confidence.png") is not None:
            figs["Plane confidence against plane error"] = "fig13_confidence.png"
    picks = F.pick_gallery(records, config.gallery)
    if picks:
        views = select_views(config)
        by_name = {n: i for i, n in enumerate(views.names)}
        F.gallery(
            [views[by_name[n]] for n, _ in picks],
            [c for _, c in picks],
            config,
            out / "gallery.png",
        )
        figs["Gallery: partial cloud, completed cloud, Mir7 mesh"] = "gallery.png"
    info["figures_s"] = time.perf_counter() - t0
    info["total_s"] = time.perf_counter() - t_start
    source = f"KTH-layout folder {config.data}" if config.data else "embedded benchmark"
    p_csv, p_json = write_tables(out, rows, summary, config.to_json(), info)
    report = write_report(out, summary, config.methods, figs, info, source, records)
    files = {"report": report, "csv": p_csv, "json": p_json}
    files.update({Path(v).stem: out / v for v in figs.values()})
    return {"summary": summary, "info": info, "files": files}
