"""Side-by-side calls of single-view kernels on a CPU."""

from __future__ import annotations

import contextlib
import os
import threading
from collections.abc import Callable, Iterable, Iterator
from typing import Any

__all__ = ["MAX_THREADS", "map_in_threads", "serial_blas"]

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


_blas_lock = threading.Lock()
_blas_state: dict = {"depth": 0, "limiter": None, "controller": None}


@contextlib.contextmanager
def serial_blas() -> Iterator[None]:
    """Runs the block with the BLAS libraries of numpy and scipy on one thread.

    Image-sized products with an inner size of 3 (``(H, W, 3) @ (3, 3)``) are memory-bound: on
    2 cores OpenBLAS's second thread gains nothing there and spins against the other work (a
    1280 x 720 segmentation: 315 -> 294 ms, half the CPU time). The limit is process-wide, so
    nested and concurrent blocks share one: the first to enter sets it, the last to leave
    restores what the process had. (OpenBLAS may ignore a limit set from a worker thread; the
    block then runs as it would without it.)
    """
    with _blas_lock:
        if _blas_state["depth"] == 0:
            if _blas_state["controller"] is None:
                import scipy.linalg  # noqa: F401  (scipy's own OpenBLAS, loaded before the scan)
                from threadpoolctl import ThreadpoolController

                _blas_state["controller"] = ThreadpoolController()
            _blas_state["limiter"] = _blas_state["controller"].limit(limits=1, user_api="blas")
        _blas_state["depth"] += 1
    try:
        yield
    finally:
        with _blas_lock:
            _blas_state["depth"] -= 1
            if _blas_state["depth"] == 0:
                _blas_state["limiter"].restore_original_limits()
                _blas_state["limiter"] = None
