"""coacd in a worker process: a crash in its C++ code (seen: a segfault on one completed mesh
in a long clear-table run) ends the worker, not the caller's job, and becomes a typed error.

One spawned worker is kept and reused (starting one costs about a second); a dead one is
replaced on the next call.
"""

from __future__ import annotations

import atexit
import concurrent.futures as cf
import multiprocessing
from collections.abc import Callable
from typing import Any

from symjax.errors import DegenerateGeometryError

__all__ = ["run_isolated"]

_POOL: cf.ProcessPoolExecutor | None = None


def _pool() -> cf.ProcessPoolExecutor:
    global _POOL
    if _POOL is None:
        # spawn, not fork: the caller has JAX's and MuJoCo's threads running.
        _POOL = cf.ProcessPoolExecutor(1, mp_context=multiprocessing.get_context("spawn"))
        # Shut it down before the interpreter tears its modules down: left to the pool's own
        # weakref callback it printed "Exception ignored ... 'NoneType' object has no
        # attribute 'util'" at exit.
        atexit.register(_shutdown)
    return _POOL


def _shutdown() -> None:
    global _POOL
    if _POOL is not None:
        _POOL.shutdown(wait=True, cancel_futures=True)
        _POOL = None


def run_isolated(fn: Callable[..., Any], *args: Any, what: str = "coacd") -> Any:
    """``fn(*args)`` in the worker process (``fn`` and the arguments must pickle).

    Raises:
        DegenerateGeometryError: The worker died while running it (a crash in native code).
    """
    global _POOL
    try:
        return _pool().submit(fn, *args).result()
    except cf.process.BrokenProcessPool:
        _POOL.shutdown(wait=False, cancel_futures=True)
        _POOL = None
        raise DegenerateGeometryError(
            f"{what} crashed on this input (its worker process died); the input is left out"
        ) from None
