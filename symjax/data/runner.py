"""``generate_dataset``: every shard (object x hand) of a data set, on this machine or on a Ray
cluster; complete shards are skipped, damaged or stale ones recomputed, and everything is
checked before the first rollout."""

from __future__ import annotations

import dataclasses
import os
import shutil
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from symjax.data.acronym_file import shard_status
from symjax.data.config import GenerateConfig
from symjax.data.manifest import collect_manifest, write_manifest
from symjax.data.objects import ObjectEntry, resolve_objects
from symjax.data.shard import run_object, shard_file
from symjax.errors import OutputError

__all__ = ["Job", "generate_dataset", "plan_jobs"]

# Room asked for before a run: about 3x and 2x what the 12-object data set's files hold (135 B a
# grasp, 0.40-0.48 MB a 640 x 480 view with its depth, points and completion).
_BYTES_PER_GRASP = 450
_BYTES_PER_VIEW = 1_000_000


@dataclasses.dataclass(frozen=True)
class Job:
    """One object's missing shards: ``hands`` holds ``(hand, shard key)`` pairs."""

    entry: ObjectEntry
    hands: tuple[tuple[str, str], ...]


def _check_output(out: Path, need: int) -> None:
    try:
        out.mkdir(parents=True, exist_ok=True)
        probe = out / f".write-test-{os.getpid()}"
        probe.write_bytes(b"symjax")
        probe.unlink()
    except OSError as e:
        raise OutputError(
            f"the output folder {str(out)!r} cannot be written ({e.strerror or e}); expected a"
            " writable folder"
        ) from None
    free = shutil.disk_usage(out).free
    if need > free:
        raise OutputError(
            f"the data set needs about {need / 1e6:.1f} MB in {str(out)!r}, which has"
            f" {free / 1e6:.1f} MB free; free some space or choose another --out-dir"
        )


def plan_jobs(cfg: GenerateConfig) -> tuple[list[Job], dict[Path, str], dict[str, int]]:
    """The jobs still to run, every shard's ``{path: key}``, and counts by status."""
    from symjax import hands

    for h in cfg.generate.hands:
        hands.load(h)
    entries = resolve_objects(cfg.generate)
    out = Path(cfg.out_dir)
    keys: dict[Path, str] = {}
    counts = {"complete": 0, "missing": 0, "stale": 0, "damaged": 0}
    jobs = []
    for e in entries:
        todo = []
        for h in cfg.generate.hands:
            key = cfg.shard_key(e.name, h, e.digest)
            path = shard_file(out, e.name, h)
            keys[path] = key
            status = shard_status(path, key)
            counts[status] += 1
            if status != "complete":
                todo.append((h, key))
        if todo:
            jobs.append(Job(e, tuple(todo)))
    return jobs, keys, counts


def generate_dataset(
    cfg: GenerateConfig,
    *,
    use_ray: bool = False,
    address: str | None = None,
    num_cpus: int | None = None,
    log: Callable[[str], None] = print,
) -> dict[str, Any]:
    """Generates (or resumes) the data set of ``cfg``; returns the manifest.

    Args:
        cfg: The :class:`GenerateConfig`.
        use_ray: Send each object's missing shards to a Ray task.
        address: A Ray cluster's address (``ray start --head`` prints it); None starts a local
            one.
        num_cpus: CPUs of a local Ray cluster (None: all).
        log: Where progress lines go.

    Returns:
        The manifest (also written to ``<out_dir>/manifest.json``).

    Raises:
        UnknownNameError, MissingFileError, FileFormatError, InvalidInputError: A bad object.
        OutputError: The output folder cannot be written or lacks the room (before any work).
    """
    t0 = time.perf_counter()
    out = Path(cfg.out_dir)
    if out.exists() and not out.is_dir():
        raise OutputError(f"out_dir {str(out)!r} is a file; expected a folder")
    jobs, keys, counts = plan_jobs(cfg)
    n_todo = sum(len(j.hands) for j in jobs)
    spec = cfg.generate
    _check_output(
        out, n_todo * (spec.n_candidates * _BYTES_PER_GRASP + spec.views * _BYTES_PER_VIEW)
    )
    log(f"{len(keys)} shards: {counts['complete']} complete in {out}, {n_todo} to compute"
        f" ({counts['damaged']} damaged, {counts['stale']} with other settings)")  # fmt: skip
    failed: list[str] = []
    try:
        if jobs and use_ray:
            from symjax.data.ray_backend import run_jobs

            failed = run_jobs(jobs, cfg, address=address, num_cpus=num_cpus, log=log)
        elif jobs:
            failed = _run_local(jobs, cfg, log)
    finally:  # an interrupted run still leaves the manifest of what is complete
        rows = collect_manifest(out, keys)
        extra = {"wall_s": round(time.perf_counter() - t0, 3), "ray": bool(use_ray),
                 "hands": list(spec.hands), "failed": failed}  # fmt: skip
        doc = write_manifest(out, rows, len(keys), {"run": extra})
    if not doc["complete"]:
        log(f"{len(keys) - len(rows)} shards are missing; rerun to compute them")
    return doc


def _run_local(jobs: list[Job], cfg: GenerateConfig, log: Callable[[str], None]) -> list[str]:
    from tqdm import tqdm

    from symjax.errors import SymjaxError, one_line

    failed = []
    total = sum(len(j.hands) for j in jobs) * cfg.generate.n_candidates
    with tqdm(total=total, unit="grasp", disable=not cfg.execution.progress,
              desc="labelled grasps", smoothing=0.05) as bar:  # fmt: skip
        for job in jobs:
            bar.set_postfix_str(job.entry.name)
            try:
                run_object(job.entry, list(job.hands), cfg, progress=bar.update)
            except OutputError:
                raise
            except SymjaxError as e:  # a bad object: the others go on
                failed.append(f"{job.entry.name}: {one_line(e, 240)}")
                log(f"{job.entry.name} failed: {one_line(e, 240)}")
    return failed
