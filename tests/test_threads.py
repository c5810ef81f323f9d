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
