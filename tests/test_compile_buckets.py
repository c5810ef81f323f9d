"""Jitted kernels compile once per shape bucket, not once per object or cloud size.

Counted from JAX's own compile log. Another test may already have compiled a bucket in this
process, so each check is that a *second* input of another size in the same bucket compiles
nothing, and that an input of a new bucket compiles at most once per kernel.
"""

from __future__ import annotations

import collections
import logging
import math
import re

import jax
import numpy as np
import pytest
import trimesh

from symjax import grasp
from symjax.geometry import bucket, cloud_bucket
from symjax.surface import poisson_reconstruct
from symjax.symmetry import search


class _Compiles(logging.Handler):
    def __init__(self):
        super().__init__(logging.DEBUG)
        self.counts: collections.Counter[str] = collections.Counter()

    def emit(self, record):
        m = re.match(r"Compiling (?:jit\()?([\w<>]+)", record.getMessage())
        if m:
            self.counts[m.group(1)] += 1


@pytest.fixture
def compiles():
    handler = _Compiles()
    logger = logging.getLogger("jax")
    old = logger.level
    logger.addHandler(handler)
    logger.setLevel(logging.DEBUG)
    with jax.log_compiles(True):
        yield handler.counts
    logger.removeHandler(handler)
    logger.setLevel(old)


def _sphere(n: int, radius: float = 0.04, seed: int = 0):
    rng = np.random.default_rng(seed)
    d = rng.normal(size=(n, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    return radius * d + [0.0, 0.0, radius], d


def test_bucket_sizes():
    assert [bucket(n) for n in (1, 256, 257, 1000, 1024, 1025, 40_000)] == [
        256, 256, 320, 1024, 1024, 1280, 40960,
    ]  # fmt: skip
    sizes = {bucket(n) for n in range(1_000, 200_001)}
    assert len(sizes) == 32  # four per doubling


def test_cloud_buckets_are_a_handful():
    assert [cloud_bucket(n) for n in (1, 1024, 1025, 40_000)] == [1024, 1024, 2048, 65536]
    assert len({cloud_bucket(n) for n in range(1_000, 200_001)}) == 9  # 1,024 ... 262,144


def test_poisson_compiles_once_per_bucket(compiles):
    from symjax.surface import PoissonConfig

    # Depth 4 is used by no other test, so the first call compiles here: the count is exact.
    cfg = PoissonConfig(depth=4)
    assert cloud_bucket(2100) == cloud_bucket(2500) != cloud_bucket(9000)
    poisson_reconstruct(*_sphere(2100), config=cfg)
    assert compiles["_poisson_jit"] == 1, dict(compiles)
    poisson_reconstruct(*_sphere(2500, seed=1), config=cfg)
    assert compiles["_poisson_jit"] == 1, dict(compiles)
    poisson_reconstruct(*_sphere(9000, seed=2), config=cfg)  # a new bucket
    assert compiles["_poisson_jit"] == 2, dict(compiles)


def test_candidate_kernels_reuse_buckets_across_meshes(compiles):
    def mesh(sections: int):
        m = trimesh.creation.cylinder(0.03, 0.12, sections=sections)
        m.apply_translation([0.5, 0.0, 0.06])
        return m

    a, b = mesh(40), mesh(56)  # 156 and 220 triangles: the same triangle bucket
    assert bucket(len(a.faces)) == bucket(len(b.faces))
    for method in grasp.METHODS:
        grasp.generate(a, method)
    compiles.clear()
    for method in grasp.METHODS:
        grasp.generate(b, method)
    assert sum(compiles.values()) == 0, dict(compiles)


def test_symmetry_search_compiles_once_per_point_bucket(compiles):
    from symjax.datasets.primitives import primitive_view

    views = [
        primitive_view("box", math.radians(30), noise=0.001, seed=s, distance=d)
        for s, d in ((0, 0.8), (1, 0.82))
    ]
    n = [v[0].n_valid for v in views]
    if cloud_bucket(n[0]) != cloud_bucket(n[1]):
        pytest.skip(f"the two views fell into different buckets: {n}")
    search(views[0][0])
    compiles.clear()
    search(views[1][0])
    assert compiles["_search_jit"] == 0, dict(compiles)
