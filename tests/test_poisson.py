"""The Poisson batch on a CPU: one view a call, views side by side in threads."""

from __future__ import annotations

import numpy as np
import pytest

from symjax.errors import SymjaxError
from symjax.surface import PoissonConfig, poisson_reconstruct, poisson_reconstruct_batch


def sphere_samples(n: int, radius: float, seed: int = 0):
    v = np.random.default_rng(seed).normal(size=(n, 3))
    v /= np.linalg.norm(v, axis=1, keepdims=True)
    return np.array([0.1, -0.2, 0.3]) + radius * v, v


def test_poisson_batch_one_by_one_is_the_single_kernel_and_keeps_errors_in_place():
    # The CPU default (views solved side by side in threads) runs the kernel of
    # poisson_reconstruct: the same mesh bit for bit, whatever the order and the other views.
    cfg = PoissonConfig(depth=5)
    views = [sphere_samples(3000 + 500 * k, 0.04 + 0.005 * k, seed=k) for k in range(5)]
    views = [(p + 0.1 * k, n) for k, (p, n) in enumerate(views)]
    bad = (np.zeros((3, 3)), np.ones((3, 3)))
    batch = poisson_reconstruct_batch([views[0], bad, *views[1:]], cfg, errors="keep")
    assert isinstance(batch[1], SymjaxError)
    meshes = [batch[0], *batch[2:]]
    for (p, n), mb in zip(views, meshes, strict=True):
        single = poisson_reconstruct(p, n, config=cfg)
        np.testing.assert_array_equal(mb.vertices, single.vertices)
        np.testing.assert_array_equal(mb.faces, single.faces)
    reverse = poisson_reconstruct_batch(views[::-1], cfg)
    for a, b in zip(meshes, reverse[::-1], strict=True):
        np.testing.assert_array_equal(a.vertices, b.vertices)
    with pytest.raises(SymjaxError):
        poisson_reconstruct_batch([views[0], bad], cfg)
