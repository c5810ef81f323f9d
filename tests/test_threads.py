"""symjax._threads: side-by-side calls keep their order and stop starting on an error."""

from __future__ import annotations

import threading
import time

import pytest

from symjax import _threads


def test_results_in_order_and_calls_side_by_side(monkeypatch):
    monkeypatch.setattr(_threads.os, "cpu_count", lambda: 2)
    running, most = 0, 0
    lock = threading.Lock()

    def job(x):
        nonlocal running, most
        with lock:
            running += 1
            most = max(most, running)
        time.sleep(0.02 * (3 - x % 3))  # later items finish first
        with lock:
            running -= 1
        return x * x

    assert _threads.map_in_threads(job, range(7)) == [x * x for x in range(7)]
    assert most == 2
    assert _threads.map_in_threads(job, []) == []


def test_an_error_drops_the_calls_not_started(monkeypatch):
    monkeypatch.setattr(_threads.os, "cpu_count", lambda: 1)
    started = []

    def job(x):
        started.append(x)
        if x == 1:
            raise KeyboardInterrupt
        time.sleep(0.01)
        return x

    with pytest.raises(KeyboardInterrupt):
        _threads.map_in_threads(job, range(50))
    assert len(started) < 50


def _blas_threads() -> int:
    """Threads of numpy's and scipy's BLAS (OpenCV's own OpenBLAS, loaded later, is not theirs)."""
    from threadpoolctl import threadpool_info

    libs = [i for i in threadpool_info() if i["user_api"] == "blas"]
    ours = [i for i in libs if "numpy" in i["filepath"] or "scipy" in i["filepath"]]
    return max(i["num_threads"] for i in ours)


def test_serial_blas_nests_and_restores_the_process_setting():
    before = _blas_threads()
    with _threads.serial_blas():
        assert _blas_threads() == 1
        with _threads.serial_blas():
            assert _blas_threads() == 1
        assert _blas_threads() == 1  # the inner block leaves the outer one's limit
    assert _blas_threads() == before


def test_serial_blas_blocks_in_threads_restore_when_the_last_leaves(monkeypatch):
    # A recording controller: OpenBLAS itself takes a limit set from a worker thread only
    # sometimes, so the bookkeeping is checked on its own.
    calls = []

    class Limiter:
        def restore_original_limits(self):
            calls.append("restore")

    class Controller:
        def limit(self, limits, user_api):
            calls.append(("limit", limits, user_api))
            return Limiter()

    monkeypatch.setitem(_threads._blas_state, "controller", Controller())
    first_in, second_in, first_out = threading.Event(), threading.Event(), threading.Event()
    seen = {}

    def first():
        with _threads.serial_blas():
            first_in.set()
            second_in.wait(5)
        first_out.set()

    def second():
        first_in.wait(5)
        with _threads.serial_blas():
            second_in.set()
            first_out.wait(5)
            seen["after_first_left"] = list(calls)

    ts = [threading.Thread(target=f) for f in (first, second)]
    for t in ts:
        t.start()
    for t in ts:
        t.join(10)
    assert seen["after_first_left"] == [("limit", 1, "blas")]
    assert calls == [("limit", 1, "blas"), "restore"]
    assert _threads._blas_state["depth"] == 0
