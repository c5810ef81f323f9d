"""Test-wide settings: persistent JAX compilation cache and shared paths."""

from __future__ import annotations

import os
import sys
from pathlib import Path

import jax
import pytest

ROOT = Path(__file__).resolve().parents[1]
SHARED = ROOT.parent / "shared"

# Compiled XLA programs are reused across test runs (CI runs start from a warm .venv/cache when the
# machine is kept) and across processes.
jax.config.update(
    "jax_compilation_cache_dir",
    os.environ.get("JAX_COMPILATION_CACHE_DIR", str(ROOT / ".venv" / "cache" / "jax")),
)
jax.config.update("jax_persistent_cache_min_compile_time_secs", 0.1)

# Every symjax cache (rendered benchmark, objects, coacd hulls) goes under .venv, never into the
# user's home: the tests share it with each other and with later runs on the same checkout.
os.environ["SYMJAX_CACHE"] = str(ROOT / ".venv" / "cache" / "symjax")

sys.path.insert(0, str(Path(__file__).parent))


@pytest.fixture(scope="session")
def shared_dir() -> Path:
    """The ../shared folder beside the checkout; tests that need it skip cleanly without it."""
    if not SHARED.is_dir():
        pytest.skip("../shared is absent")
    return SHARED


@pytest.fixture
def strict_ranks():
    """Implicit rank promotion hides shape bugs: tests of JAX kernels run with it as an error."""
    with jax.numpy_rank_promotion("raise"):
        yield
