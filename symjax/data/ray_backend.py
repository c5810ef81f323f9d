"""Ray tasks for :func:`~symjax.data.generate_dataset`: one task per object (its missing shards),
``num_gpus=1`` where the cluster has GPUs. A task whose worker dies is retried by Ray; the retry
skips the shards its first run completed (every shard file is written whole or not at all), so
no shard is lost or written twice, and the driver rebuilds the manifest from the files.
"""

from __future__ import annotations

import os
import socket
from collections.abc import Callable
from pathlib import Path
from typing import Any

from symjax.errors import InvalidInputError, SymjaxError

__all__ = ["RUNNING_DIR", "run_jobs"]

#: Folder of ``<object>.json`` markers of the tasks in flight (pid, host), under out_dir.
RUNNING_DIR = ".running"

MAX_RETRIES = 3


def _task(job: Any, cfg: Any) -> list[dict[str, Any]]:
    """Runs one job in a Ray worker; a retry recomputes only what is still missing."""
    import json

    from symjax.data.acronym_file import shard_status
    from symjax.data.shard import run_object, shard_file

    out = Path(cfg.out_dir)
    marker = out / RUNNING_DIR / f"{job.entry.name}.json"
    marker.parent.mkdir(parents=True, exist_ok=True)
    marker.write_text(json.dumps({"pid": os.getpid(), "host": socket.gethostname()}))
    todo = [(h, k) for h, k in job.hands
            if shard_status(shard_file(out, job.entry.name, h), k) != "complete"]  # fmt: skip
    rows = run_object(job.entry, todo, cfg) if todo else []
    marker.unlink(missing_ok=True)
    return rows


def run_jobs(jobs: list, cfg: Any, *, address: str | None, num_cpus: int | None,
             log: Callable[[str], None]) -> list[str]:  # fmt: skip
    """Runs ``jobs`` as Ray tasks and waits for all of them.

    Returns:
        One line per object whose task failed (its error; the other shards are kept).

    Raises:
        InvalidInputError: Ray is not installed, or the cluster cannot be reached.
    """
    from tqdm import tqdm

    try:
        import ray
    except ImportError:
        raise InvalidInputError(
            "--ray needs Ray: pip install 'symjax[ray]' (or pip install ray)"
        ) from None
    started = False
    if not ray.is_initialized():
        try:
            if address is not None:
                ray.init(address=address, log_to_driver=False)
            else:
                ray.init(num_cpus=num_cpus, include_dashboard=False, log_to_driver=False)
        except (ConnectionError, RuntimeError, ValueError) as e:
            raise InvalidInputError(
                f"cannot reach the Ray cluster at {address or 'a new local cluster'}: {e}"
            ) from None
        started = True
    try:
        gpus = ray.cluster_resources().get("GPU", 0)
        remote = ray.remote(num_cpus=1, num_gpus=1 if gpus else 0, max_retries=MAX_RETRIES)(_task)
        pending = {remote.remote(j, cfg): j for j in jobs}
        log(f"ray: {len(pending)} tasks on {ray.cluster_resources().get('CPU', 0):.0f} CPUs,"
            f" {gpus:.0f} GPUs")  # fmt: skip
        errors = []
        n = cfg.generate.n_candidates
        # Per task, not per rollout chunk: the bar moves when an object's shards are written.
        total = sum(len(j.hands) for j in jobs) * n
        off = not cfg.execution.progress
        with tqdm(total=total, unit="grasp", disable=off, desc="labelled grasps (ray)") as bar:
            while pending:
                ready, _ = ray.wait(list(pending), num_returns=1)
                job = pending.pop(ready[0])
                try:
                    ray.get(ready[0])
                except ray.exceptions.RayTaskError as e:
                    cause = e.cause if isinstance(getattr(e, "cause", None), SymjaxError) else e
                    errors.append(f"{job.entry.name}: {str(cause).splitlines()[-1]}")
                except ray.exceptions.WorkerCrashedError as e:
                    errors.append(f"{job.entry.name}: worker died {MAX_RETRIES + 1} times ({e})")
                bar.update(len(job.hands) * n)
                bar.set_postfix_str(job.entry.name)
        return errors
    finally:
        if started:
            ray.shutdown()
