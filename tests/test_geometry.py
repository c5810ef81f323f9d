"""The shared geometry module's point-triangle kernel against simple references."""

from __future__ import annotations

import numpy as np
import pytest

from symjax.geometry import closest_point_on_triangle


def _dense(tri: np.ndarray, n: int = 60) -> np.ndarray:
    """(T, S, 3) barycentric grid samples of each triangle."""
    bary = np.array([(i, j) for i in range(n + 1) for j in range(n + 1 - i)]) / n
    w = np.column_stack([1 - bary.sum(1), bary])
    return np.einsum("sk,tkd->tsd", w, tri)


def test_closest_point_never_beaten_by_a_dense_sampling():
    rng = np.random.default_rng(0)
    tri = rng.normal(0, 0.05, size=(400, 3, 3))
    p = rng.normal(0, 0.08, size=(400, 3))
    q = closest_point_on_triangle(p, tri)
    d = np.linalg.norm(q - p, axis=1)
    samples = np.linalg.norm(_dense(tri) - p[:, None], axis=2).min(1)
    assert np.all(d <= samples + 1e-12)
    # The grid's spacing bounds how far above the true distance its minimum can be.
    spacing = np.linalg.norm(tri - tri[:, [1, 2, 0]], axis=2).max(1) / 60
    assert np.all(samples - d <= spacing)
    # And the answer is a point of the triangle: non-negative barycentric coordinates.
    a, b, c = tri[:, 0], tri[:, 1], tri[:, 2]
    n = np.cross(b - a, c - a)
    uvw = np.linalg.solve(np.stack([b - a, c - a, n], axis=2), (q - a)[..., None])[..., 0]
    assert uvw[:, :2].min() >= -1e-9 and uvw[:, :2].sum(1).max() <= 1 + 1e-9
    np.testing.assert_allclose(uvw[:, 2], 0, atol=1e-9)  # in the triangle's plane


def test_point_above_a_small_triangle_is_at_its_plane_distance():
    """A case trimesh.triangles.closest_point put 60 times too far (1.4e-4 against 2.4e-6 m)."""
    tri = np.array([[[0.04839405, 0.00878864, 0.00888149],
                     [0.04855292, 0.00879404, 0.00807448],
                     [0.04831551, 0.00965483, 0.00854572]]])  # fmt: skip
    p = np.array([[0.04840816, 0.00897996, 0.00866078]])
    a, b, c = tri[0]
    n = np.cross(b - a, c - a)
    n /= np.linalg.norm(n)
    proj = p[0] - n * np.dot(p[0] - a, n)
    uv = np.linalg.solve(np.column_stack([b - a, c - a, n]), proj - a)[:2]
    assert uv.min() > 0 and uv.sum() < 1  # the projection falls inside
    q = closest_point_on_triangle(p, tri)
    np.testing.assert_allclose(q[0], proj, atol=1e-15)
    assert np.linalg.norm(q[0] - p[0]) == pytest.approx(abs(np.dot(p[0] - a, n)), abs=1e-15)


@pytest.mark.parametrize(
    "tri",
    [
        [[0, 0, 0], [1, 0, 0], [2, 0, 0]],  # collinear
        [[0, 0, 0], [1, 0, 0], [1, 0, 0]],  # two vertices coincide
        [[0.5, 0, 0], [0.5, 0, 0], [0.5, 0, 0]],  # a point
    ],
)
def test_degenerate_triangles_give_their_closest_edge_point(tri):
    tri = np.asarray(tri, float)
    rng = np.random.default_rng(1)
    p = rng.normal(0, 1.0, size=(200, 3))
    q = closest_point_on_triangle(p, np.repeat(tri[None], len(p), axis=0))
    assert np.all(np.isfinite(q))
    # The segment the degenerate triangle spans, densely sampled.
    lo, hi = tri[np.argmin(tri[:, 0])], tri[np.argmax(tri[:, 0])]
    seg = lo + np.linspace(0, 1, 2001)[:, None] * (hi - lo)
    ref = np.linalg.norm(seg[None] - p[:, None], axis=2).min(1)
    np.testing.assert_allclose(np.linalg.norm(q - p, axis=1), ref, atol=1e-3)
    assert np.all(np.linalg.norm(q - p, axis=1) <= ref + 1e-12)
