"""Side-by-side calls of single-view kernels on a CPU."""

from __future__ import annotations

import os
from collections.abc import Callable, Iterable
from typing import Any

__all__ = ["MAX_THREADS", "map_in_threads"]

#: Threads at most, whatever the core count: each call holds its own intermediates (a depth-7
#: Poisson view ~150 MB) while it runs.
MAX_THREADS = 8


def map_in_threads(fn: Callable[[Any], Any], items: Iterable[Any]) -> list:
    """``[fn(x) for x in items]``, several calls at a time in threads (one per core, at most
    :data:`MAX_THREADS`), in order.

    One XLA:CPU program runs its FFTs, sorts and scatters on one core, and JAX's asynchronous
    dispatch runs the calls of one thread one after the other, so single-view calls from
    several threads fill the cores. On Ctrl-C (or any error) the calls not started are dropped.
    """
    from concurrent.futures import ThreadPoolExecutor

    items = list(items)
    threads = max(1, min(len(items), os.cpu_count() or 1, MAX_THREADS))
    pool = ThreadPoolExecutor(threads)
    try:
        return list(pool.map(fn, items))
    finally:
        pool.shutdown(wait=True, cancel_futures=True)
