"""Ray casts against meshes: batched against one-by-one against a float64 numpy reference.

The batched kernel once gave ``inf`` to every ray after the first of a vmapped batch on meshes
of 20k triangles and more (XLA fused two reductions across the batch): the KTH generator then
found "no surface across the centroid" on every Poisson mesh. These tests use large meshes and
opposite rays, the case that failed.
"""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from symjax import grasp


def nearest_hits(origins, directions, tri, t_min=1e-9):
    """Nearest hit per ray, float64 Moller-Trumbore over every triangle (T, 3, 3): (R,) t, inf
    if none (shared with test_datasets)."""
    v0, e1, e2 = tri[:, 0], tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]
    out = np.full(len(directions), np.inf)
    for k, (o, d) in enumerate(zip(np.broadcast_to(origins, np.shape(directions)), directions,
                                   strict=True)):  # fmt: skip
        p = np.cross(d, e2)
        det = np.einsum("ij,ij->i", e1, p)
        ok = np.abs(det) > 1e-15
        inv = np.where(ok, 1.0 / np.where(ok, det, 1.0), 0.0)
        s = o - v0
        u = np.einsum("ij,ij->i", s, p) * inv
        q = np.cross(s, e1)
        w = q @ d * inv
        t = np.einsum("ij,ij->i", e2, q) * inv
        hit = ok & (u >= 0) & (w >= 0) & (u + w <= 1) & (t > t_min)
        if hit.any():
            out[k] = t[hit].min()
    return out


def _reference(origins, directions, v, f):
    return nearest_hits(origins, directions, v[f])


@pytest.fixture(scope="module")
def sphere():
    """81,920 triangles, 5 cm radius, a metre from the origin (a Poisson mesh's size and place)."""
    m = trimesh.creation.icosphere(6, radius=0.05)
    m.apply_translation((0.6, -0.1, 0.8))
    return np.asarray(m.vertices), np.asarray(m.faces)


def _opposite_rays(centre, n, far, seed):
    rng = np.random.default_rng(seed)
    u = rng.normal(size=(n, 3))
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    origins = np.concatenate([centre + far * u, centre - far * u])
    return origins, np.concatenate([-u, u])


def test_batched_rays_match_one_by_one_and_reference(sphere):
    v, f = sphere
    origins, dirs = _opposite_rays(v.mean(0), 12, 0.3, seed=0)
    t_batch, face = grasp.cast_rays(origins, dirs, sphere)
    t_one = np.array([grasp.cast_rays(origins[i : i + 1], dirs[i : i + 1], sphere)[0][0]
                      for i in range(len(origins))])  # fmt: skip
    t_ref = _reference(origins, dirs, v, f)
    assert np.all(np.isfinite(t_ref))
    np.testing.assert_allclose(t_batch, t_ref, atol=2e-5)
    np.testing.assert_allclose(t_one, t_ref, atol=2e-5)
    assert np.all(face >= 0) and np.all(face < len(f))
    # Rays that miss stay misses in the batch: shift half of them off the sphere.
    off = origins.copy()
    side = np.cross(dirs[::2], [0.3, 0.5, 0.8])
    off[::2] += 0.2 * side / np.linalg.norm(side, axis=1, keepdims=True)
    t_mix, _ = grasp.cast_rays(off, dirs, sphere)
    np.testing.assert_allclose(t_mix, _reference(off, dirs, v, f), atol=2e-5)
    assert np.isinf(t_mix[::2]).all() and np.isfinite(t_mix[1::2]).all()


def test_inside_test_batched_matches_reference(sphere):
    v, _ = sphere
    c = v.mean(0)
    rng = np.random.default_rng(1)
    pts = c + rng.uniform(-0.06, 0.06, size=(300, 3))
    r = np.linalg.norm(pts - c, axis=1)
    keep = np.abs(r - 0.05) > 1e-3  # away from the faceted surface
    inside = grasp.inside_mesh(pts[keep], sphere)
    np.testing.assert_array_equal(inside, r[keep] < 0.05)


def test_kth_points_on_a_large_mesh(sphere):
    v, _ = sphere
    pts = grasp.kth_grasp_points(sphere)
    np.testing.assert_allclose(np.linalg.norm(pts - v.mean(0), axis=1), 0.05, atol=5e-4)
    assert np.linalg.norm(pts[0] - pts[1]) > 0.099
