"""symjax.perception.hull: OpenCV's convex hull, after dropping points that cannot be vertices."""

from __future__ import annotations

import cv2
import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from symjax.perception.hull import convex_hull_2d


def _cloud(kind: int, n: int, rng: np.random.Generator) -> np.ndarray:
    if kind == 0:  # a filled blob
        return rng.normal(size=(n, 2))
    if kind == 1:  # a ring: most points are vertices or next to one
        t = rng.uniform(0.0, 2.0 * np.pi, n)
        return rng.uniform(0.9, 1.0, (n, 1)) * np.c_[np.cos(t), np.sin(t)]
    if kind == 2:  # a coarse grid: duplicates and collinear points on every edge
        return np.round(rng.uniform(-1.0, 1.0, (n, 2)) * 20.0) / 20.0
    return rng.uniform(-1.0, 1.0, (n, 2)) * [0.1, 1e-4]  # a sliver


@settings(max_examples=60, deadline=None)
@given(
    kind=st.integers(0, 3),
    n=st.integers(3, 5000),
    scale=st.floats(1e-3, 10.0),
    seed=st.integers(0, 2**31 - 1),
)
def test_hull_is_opencvs_hull_of_all_points(kind, n, scale, seed):
    rng = np.random.default_rng(seed)
    p = _cloud(kind, n, rng) * scale + rng.normal(size=2)
    want = cv2.convexHull(p.astype(np.float32), clockwise=False).reshape(-1, 2)
    got = convex_hull_2d(p)
    assert got.dtype == np.float64
    np.testing.assert_array_equal(got, want.astype(np.float64))


def test_hull_of_collinear_and_repeated_points():
    line = np.c_[np.linspace(0.0, 1.0, 200), np.linspace(0.0, 2.0, 200)]
    same = np.ones((100, 2))
    for p in (line, same, np.concatenate([line, line])):
        want = cv2.convexHull(p.astype(np.float32), clockwise=False).reshape(-1, 2)
        np.testing.assert_array_equal(convex_hull_2d(p), want)
