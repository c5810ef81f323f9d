"""Convex decomposition: coacd hulls, vertex cap, disk cache and the object MJCF."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest
import trimesh
from mujoco import mjx
from scipy.spatial import ConvexHull

from symjax.decompose import (
    DecomposeConfig,
    cap_hull,
    decompose,
    mass_properties,
    mesh_key,
    object_spec,
    object_xml,
)
from symjax.errors import ConfigError, DegenerateGeometryError, ShapeError

FAST = DecomposeConfig(threshold=0.1, max_hulls=8, resolution=500, mcts_iterations=40)


@pytest.fixture(scope="module")
def ring():
    m = trimesh.creation.annulus(0.02, 0.04, 0.05)  # non-convex: coacd must split it
    return np.asarray(m.vertices), np.asarray(m.faces)


def test_cache_hits_on_second_call(ring, tmp_path):
    v, f = ring
    first = decompose((v, f), FAST, cache_dir=tmp_path)
    second = decompose((v, f), FAST, cache_dir=tmp_path)
    assert not first.cache_hit and second.cache_hit
    assert second.key == first.key == mesh_key((v, f), FAST)
    assert first.n_hulls == second.n_hulls >= 2
    for (v1, f1), (v2, f2) in zip(first.hulls, second.hulls, strict=True):
        np.testing.assert_array_equal(v1, v2)
        np.testing.assert_array_equal(f1, f2)
    # Written atomically: only the entry, no temporary files.
    assert [p.name for p in tmp_path.iterdir()] == [f"{first.key}.npz"]
    # Another setting is another entry.
    other = decompose((v, f), DecomposeConfig(**{**FAST.__dict__, "max_vertices": 8}), tmp_path)
    assert not other.cache_hit and other.key != first.key
    assert all(len(hv) <= 8 for hv, _ in other.hulls)


def test_hulls_are_capped_convex_and_cover_the_ring(ring, tmp_path):
    v, f = ring
    dec = decompose((v, f), FAST, cache_dir=tmp_path)
    total = 0.0
    for hv, _ in dec.hulls:
        assert len(hv) <= FAST.max_vertices
        # Every vertex is on its own hull: the hull is convex.
        assert len(ConvexHull(hv).vertices) == len(hv)
        total += ConvexHull(hv).volume
    vol = trimesh.Trimesh(v, f).volume
    # Hulls approximate the ring: not the filled disc (whose volume is 4/3 of the ring's).
    assert 0.8 * vol < total < 1.25 * vol


def test_corrupt_cache_entry_is_recomputed(ring, tmp_path):
    v, f = ring
    key = mesh_key((v, f), FAST)
    (tmp_path / f"{key}.npz").write_bytes(b"not a zip")
    dec = decompose((v, f), FAST, cache_dir=tmp_path)
    assert not dec.cache_hit and dec.n_hulls >= 2
    assert decompose((v, f), FAST, cache_dir=tmp_path).cache_hit


def test_cap_hull_caps_and_orients():
    rng = np.random.default_rng(0)
    p = rng.normal(size=(500, 3))
    p /= np.linalg.norm(p, axis=1, keepdims=True)
    hv, hf = cap_hull(p, 20)
    assert len(hv) == 20
    normals = np.cross(hv[hf[:, 1]] - hv[hf[:, 0]], hv[hf[:, 2]] - hv[hf[:, 0]])
    assert np.all(np.einsum("ij,ij->i", normals, hv[hf[:, 0]] - hv.mean(0)) > 0)
    with pytest.raises(DegenerateGeometryError):
        cap_hull(np.c_[rng.normal(size=(20, 2)), np.zeros(20)], 20)


def test_object_spec_mass_inertia_free_joint_and_mjx():
    box = trimesh.creation.box([0.1, 0.06, 0.2])
    hulls = [(np.asarray(box.vertices), np.asarray(box.faces))]
    spec = object_spec(hulls, name="obj", mass=0.5, pos=(0.1, 0, 0.3))
    m = spec.compile()
    b = m.body("obj")
    assert b.mass[0] == pytest.approx(0.5)
    # Box inertia m/12 (b^2 + c^2), principal axes along the box.
    expected = 0.5 / 12 * np.array([0.06**2 + 0.2**2, 0.1**2 + 0.2**2, 0.1**2 + 0.06**2])
    np.testing.assert_allclose(np.sort(b.inertia), np.sort(expected), rtol=1e-6)
    assert m.jnt_type[m.joint("obj").id] == mujoco.mjtJoint.mjJNT_FREE
    assert m.ngeom == 1 and m.geom_type[0] == mujoco.mjtGeom.mjGEOM_MESH
    assert mjx.put_model(m).nq == 7
    # Mass from density when no mass is given.
    mass, com, _ = mass_properties(box.vertices, box.faces, 1000.0)
    assert mass == pytest.approx(1.2) and np.allclose(com, 0)
    xml = object_xml(hulls, name="obj", density=1000.0)
    assert "freejoint" in xml or 'type="free"' in xml
    assert mujoco.MjModel.from_xml_string(xml).body("obj").mass[0] == pytest.approx(1.2)


def test_bad_input_raises():
    with pytest.raises(ShapeError):
        decompose((np.zeros((10, 2)), np.zeros((4, 3), int)), use_cache=False)
    with pytest.raises(ShapeError):
        decompose((np.zeros((10, 3)), np.full((4, 3), 99)), use_cache=False)
    with pytest.raises(ConfigError):
        DecomposeConfig(max_vertices=3)


def test_a_decomposition_moves_rigidly_without_coacd(ring, tmp_path):
    dec = decompose(ring, FAST, cache_dir=tmp_path)
    T = np.eye(4)
    T[:3, :3] = trimesh.transformations.rotation_matrix(0.7, (0, 0, 1))[:3, :3]
    T[:3, 3] = (0.6, -0.2, 0.8)
    moved = dec.transformed(T)
    assert moved.n_hulls == dec.n_hulls and moved.key != dec.key
    for (v0, f0), (v1, f1) in zip(dec.hulls, moved.hulls, strict=True):
        np.testing.assert_allclose(v1, v0 @ T[:3, :3].T + T[:3, 3], atol=1e-12)
        np.testing.assert_array_equal(f0, f1)
        assert ConvexHull(v1).volume == pytest.approx(ConvexHull(v0).volume, rel=1e-9)
    # Moving back gives the hulls again; the cache holds only the one coacd entry.
    back = moved.transformed(np.linalg.inv(T))
    for (v0, _), (v2, _) in zip(dec.hulls, back.hulls, strict=True):
        np.testing.assert_allclose(v2, v0, atol=1e-12)
    assert len(list(tmp_path.iterdir())) == 1


def test_large_meshes_are_simplified_before_coacd(tmp_path, monkeypatch):
    """A Poisson-sized mesh (20k faces) reaches coacd decimated to ``max_faces``; the hulls still
    cover it (coacd took 12 to 110 s on completed meshes of 55k-104k faces)."""
    from symjax.decompose import hulls as hulls_module

    seen = []
    real = hulls_module._run_coacd

    def spy(v, f, config, closed):
        seen.append((len(f), closed))
        return real(v, f, config, closed)

    monkeypatch.setattr(hulls_module, "_run_coacd", spy)
    m = trimesh.creation.capsule(0.12, 0.03, count=[100, 100])
    assert len(m.faces) > 15000
    dec = decompose(m, DecomposeConfig(max_faces=1500), cache_dir=tmp_path)
    assert seen[0][0] <= 1500 and seen[0][1]  # decimated; the input was closed
    vol = sum(ConvexHull(v).volume for v, _ in dec.hulls)
    assert abs(vol - m.volume) < 0.1 * m.volume  # 64-vertex hulls cut a little off
    v, f = np.asarray(m.vertices), np.asarray(m.faces)
    assert hulls_module.simplify(v, f, 0)[1] is f  # max_faces = 0 keeps every face


def test_a_crash_in_the_worker_is_a_typed_error_and_the_next_call_works():
    import os

    from symjax.decompose.worker import run_isolated

    with pytest.raises(DegenerateGeometryError, match="crashed"):
        run_isolated(os._exit, 3)  # the worker dies as a segfaulting coacd would
    assert run_isolated(abs, -2) == 2  # a new worker


def test_a_worker_that_runs_too_long_is_stopped_and_the_next_call_works():
    import time

    from symjax.decompose.worker import run_isolated

    t0 = time.perf_counter()
    with pytest.raises(DegenerateGeometryError, match="longer than 1 s"):
        run_isolated(time.sleep, 60, timeout=1.0)  # as coacd spinning on a mesh
    assert time.perf_counter() - t0 < 30
    assert run_isolated(abs, -2) == 2  # a new worker
