"""coacd in a worker process: a crash in its C++ code (seen: a segfault on one completed mesh
in a long clear-table run) ends the worker, not the caller's job, and becomes a typed error.

One spawned worker is kept and reused (starting one costs about a second); a dead one is
replaced on the next call. A call that runs longer than :data:`TIMEOUT_S` is given up and its
worker killed (seen: coacd spinning for over 15 minutes on one completed mesh in a long
clear-table run, where a decomposition takes seconds).
"""

from __future__ import annotations

import atexit
import concurrent.futures as cf
import multiprocessing
from collections.abc import Callable
from typing import Any

from symjax.errors import DegenerateGeometryError

__all__ = ["TIMEOUT_S", "run_isolated"]

#: Seconds after which a call is given up (a decomposition takes 0.1 to 3 s).
TIMEOUT_S = 120.0

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


def _discard() -> None:
    """Kills the worker (it may be spinning) and forgets the pool."""
    global _POOL
    if _POOL is not None:
        for p in list(getattr(_POOL, "_processes", {}).values()):
            p.kill()
        _POOL.shutdown(wait=False, cancel_futures=True)
        _POOL = None


def run_isolated(
    fn: Callable[..., Any], *args: Any, what: str = "coacd", timeout: float | None = None
) -> Any:
    """``fn(*args)`` in the worker process (``fn`` and the arguments must pickle).

    Args:
        timeout: Seconds to wait (default :data:`TIMEOUT_S`).

    Raises:
        DegenerateGeometryError: The worker died while running it (a crash in native code), or
            it ran longer than ``timeout``.
    """
    limit = TIMEOUT_S if timeout is None else float(timeout)
    try:
        return _pool().submit(fn, *args).result(timeout=limit)
    except cf.process.BrokenProcessPool:
        _discard()
        raise DegenerateGeometryError(
            f"{what} crashed on this input (its worker process died); the input is left out"
        ) from None
    except cf.TimeoutError:
        _discard()
        raise DegenerateGeometryError(
            f"{what} ran longer than {limit:g} s on this input (its worker was stopped); the"
            " input is left out"
        ) from None
