"""Ctrl-C that cannot be lost: the console's SIGINT handler records the interrupt as well as
raising it, because CPython drops exceptions raised inside garbage-collector callbacks (JAX
registers one), which would let a run go on and exit 0."""

from __future__ import annotations

import signal
import threading

__all__ = ["check", "install", "interrupted"]

_FLAG = threading.Event()


def _handler(signum, frame) -> None:
    _FLAG.set()
    if frame is not None and frame.f_code.co_name.endswith("gc_callback"):
        # Raised here it would be dropped and its traceback printed ("Exception ignored in"):
        # the next check() raises it instead.
        return
    raise KeyboardInterrupt


def install() -> None:
    """Installs the recording handler (the console command does, before any heavy import)."""
    signal.signal(signal.SIGINT, _handler)


def interrupted() -> bool:
    """Whether Ctrl-C was pressed since :func:`install`."""
    return _FLAG.is_set()


def check() -> None:
    """Raises ``KeyboardInterrupt`` if an interrupt was recorded (and perhaps swallowed)."""
    if _FLAG.is_set():
        raise KeyboardInterrupt
