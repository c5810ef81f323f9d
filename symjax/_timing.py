"""Wall-clock timing and result rows shared by the benchmark scripts."""

from __future__ import annotations

import json
import os
import statistics
import time
from collections.abc import Callable
from typing import Any

__all__ = ["JsonRows", "median_p95", "median_time"]


class JsonRows:
    """A benchmark's rows: each printed as one JSON line and the whole list rewritten atomically
    to ``path`` after it, so that a run killed half-way keeps what it measured.

    Args:
        path: The results file (``bench/results/<name>.json``).
        meta: Fields added to every row (machine, backend, preset).
    """

    def __init__(self, path: str | os.PathLike, meta: dict | None = None) -> None:
        self.path = path
        self.meta = dict(meta or {})
        self.rows: list[dict] = []

    def emit(self, row: dict) -> dict:
        """Prints, keeps and writes ``row`` (with the meta fields); returns it."""
        from symjax._atomic import atomic_write_json

        row = {**row, **self.meta}
        print(json.dumps(row), flush=True)
        self.rows.append(row)
        atomic_write_json(self.path, self.rows)
        return row


def median_time(fn: Callable[[], Any], repeats: int) -> float:
    """Median wall time (s) of ``fn()`` over ``repeats`` calls; ``fn`` must block until its
    result is ready (``jax.block_until_ready``), or the time is the dispatch alone."""
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times)


def median_p95(x, digits: int = 5) -> dict:
    """``{"median", "p95"}`` of a sample (None for an empty one), rounded: a benchmark row's
    statistics of a per-query time or error."""
    import numpy as np

    x = np.asarray(x, float)
    if len(x) == 0:
        return {"median": None, "p95": None}
    return {"median": round(float(np.median(x)), digits),
            "p95": round(float(np.percentile(x, 95)), digits)}  # fmt: skip
