"""Kernels stored as exported StableHLO (symjax._kernel_store): same results as the plain jit,
loaded by a later process without tracing, robust to a damaged store."""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from symjax._kernel_store import StoredKernel, store_dir

TRACES: list[int] = []


def _kernel(x, y, scale: float):
    TRACES.append(1)  # runs only while JAX traces
    return {"sum": jnp.sum(x * scale) + y, "rows": jnp.cumsum(x, axis=0)}


@pytest.fixture
def store(tmp_path):
    old = jax.config.jax_compilation_cache_dir
    jax.config.update("jax_compilation_cache_dir", str(tmp_path))
    TRACES.clear()
    yield tmp_path / "symjax-export"
    jax.config.update("jax_compilation_cache_dir", old)


def _args(n=5):
    return np.arange(3.0 * n, dtype=np.float32).reshape(n, 3), np.float32(2.0)


def test_stored_kernel_matches_plain_jit_and_stores_once(store):
    k = StoredKernel(_kernel, (2,), "_toy")
    x, y = _args()
    got = k(x, y, 0.5)
    want = jax.jit(_kernel, static_argnums=(2,))(x, y, 0.5)
    for key in ("sum", "rows"):
        np.testing.assert_array_equal(np.asarray(got[key]), np.asarray(want[key]))
    assert len(list(store.iterdir())) == 1
    k(x + 1, y, 0.5)  # same signature: neither traced nor stored again
    assert len(list(store.iterdir())) == 1
    k(*_args(7), 0.5)  # a new shape and a new static value are new signatures
    k(x, y, 0.25)
    assert len(list(store.iterdir())) == 3


def test_a_new_process_loads_without_tracing(store):
    x, y = _args()
    first = StoredKernel(_kernel, (2,), "_toy")(x, y, 0.5)
    TRACES.clear()
    again = StoredKernel(_kernel, (2,), "_toy")(x, y, 0.5)  # a fresh kernel: an empty memo
    assert TRACES == []
    np.testing.assert_array_equal(np.asarray(first["rows"]), np.asarray(again["rows"]))


def test_a_damaged_store_is_exported_again(store):
    x, y = _args()
    want = np.asarray(StoredKernel(_kernel, (2,), "_toy")(x, y, 0.5)["sum"])
    (path,) = store.iterdir()
    path.write_bytes(b"not a kernel")
    TRACES.clear()
    got = StoredKernel(_kernel, (2,), "_toy")(x, y, 0.5)
    assert TRACES  # traced again, and the file replaced
    assert path.read_bytes() != b"not a kernel"
    np.testing.assert_array_equal(np.asarray(got["sum"]), want)


def test_without_a_cache_folder_it_is_a_plain_jit():
    old = jax.config.jax_compilation_cache_dir
    jax.config.update("jax_compilation_cache_dir", None)
    try:
        assert store_dir() is None
        out = StoredKernel(_kernel, (2,), "_toy")(*_args(), 0.5)
        np.testing.assert_allclose(float(out["sum"]), 0.5 * np.arange(15.0).sum() + 2.0)
    finally:
        jax.config.update("jax_compilation_cache_dir", old)


def test_symmetry_search_through_the_store_matches_the_plain_kernel():
    from symjax.datasets.primitives import primitive_view
    from symjax.execution import ExecutionConfig
    from symjax.geometry import cloud_bucket
    from symjax.symmetry import SymmetryConfig, search
    from symjax.symmetry.solver import _search_jit
    from symjax.symmetry.view import prepare_view

    if store_dir() is None:
        pytest.skip("the tests run without a persistent compilation cache")
    obs = primitive_view("box", 0.5, noise=0.001, seed=3)[0]
    got = search(obs)
    view = prepare_view(obs, cloud_bucket(len(np.asarray(obs.points))))
    plain = _search_jit.jit(view, SymmetryConfig(), ExecutionConfig().symmetry_chunk_hypotheses)
    np.testing.assert_array_equal(np.asarray(got.normal), np.asarray(plain.normal))
    np.testing.assert_array_equal(np.asarray(got.votes), np.asarray(plain.votes))
