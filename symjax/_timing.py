"""Wall-clock timing shared by the benchmark scripts."""

from __future__ import annotations

import statistics
import time
from collections.abc import Callable
from typing import Any

__all__ = ["median_p95", "median_time"]


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
