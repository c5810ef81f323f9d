"""Mesh deviation and centroid error against analytic values (paper Section V-A.3, V-B)."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from symjax.errors import EmptyInputError, InvalidInputError, ShapeError, SymjaxError
from symjax.metrics import (
    centroid_error,
    mesh_deviation,
    sample_surface,
    surface_centroid,
    surface_distance,
)

EXTENTS = np.array([0.12, 0.07, 0.10])


def box_distance(points: np.ndarray, extents: np.ndarray, centre: np.ndarray) -> np.ndarray:
    """Exact distance of points to the surface of an axis-aligned box."""
    q = np.abs(points - centre) - extents / 2
    outside = np.linalg.norm(np.maximum(q, 0.0), axis=1)
    inside = -np.max(q, axis=1)
    return np.where(np.all(q <= 0, axis=1), inside, outside)


@pytest.fixture(scope="module")
def sphere():
    return trimesh.creation.icosphere(subdivisions=5, radius=0.05)


def test_sphere_vs_scaled_sphere(sphere):
    big = sphere.copy()
    big.apply_scale(1.1)
    for ref, other in ((sphere, big), (big, sphere)):
        dev = mesh_deviation(ref, other, n_samples=5000, seed=1)
        # Radii differ by 5 mm; the tessellation (sagitta ~ 5 um) blurs it slightly.
        assert dev.mean == pytest.approx(0.005, abs=2e-5)
        assert dev.max == pytest.approx(0.005, abs=3e-5)
        assert dev.variance < 1e-10
        assert dev.n == 5000
        vals = [dev.percentiles[p] for p in sorted(dev.percentiles)]
        assert np.all(np.diff(vals) >= 0) and vals[0] <= dev.mean <= dev.max
    assert mesh_deviation(sphere, sphere, n_samples=2000).max < 1e-12


def test_surface_distance_matches_analytic_box():
    box = trimesh.creation.box(extents=EXTENTS)
    rng = np.random.default_rng(3)
    pts = rng.uniform(-0.12, 0.12, size=(3000, 3))
    np.testing.assert_allclose(
        surface_distance(pts, box), box_distance(pts, EXTENTS, np.zeros(3)), atol=1e-12
    )


def test_surface_distance_matches_brute_force():
    mesh = trimesh.creation.icosphere(subdivisions=2, radius=0.05)
    mesh.vertices += np.random.default_rng(0).normal(0, 0.004, mesh.vertices.shape)
    pts = np.random.default_rng(1).normal(0, 0.04, size=(300, 3))
    # Brute force: the minimum over every triangle of the distance to a dense sampling of it.
    bary = np.array([(i, j) for i in range(41) for j in range(41 - i)]) / 40.0
    tri = mesh.triangles
    dense = (
        tri[:, None, 0] * (1 - bary.sum(1))[None, :, None]
        + tri[:, None, 1] * bary[None, :, 0, None]
        + tri[:, None, 2] * bary[None, :, 1, None]
    ).reshape(-1, 3)
    from scipy.spatial import cKDTree

    ref, _ = cKDTree(dense).query(pts)
    got = surface_distance(pts, mesh)
    # The dense sampling overestimates by at most its spacing (~0.2 mm) and never underestimates.
    assert np.all(got <= ref + 1e-12)
    np.testing.assert_allclose(got, ref, atol=3e-4)


@pytest.mark.parametrize("shift", [0.004, 0.02])
def test_box_vs_shifted_box(shift):
    ref = trimesh.creation.box(extents=EXTENTS)
    moved = ref.copy()
    moved.apply_translation([shift, 0.0, 0.0])
    dev = mesh_deviation(ref, moved, n_samples=20000, seed=5)
    d = box_distance(sample_surface(ref, 20000, seed=5), EXTENTS, np.array([shift, 0.0, 0.0]))
    assert dev.mean == pytest.approx(d.mean(), abs=1e-12)
    assert dev.variance == pytest.approx(d.var(), abs=1e-12)
    assert dev.max == pytest.approx(shift, abs=1e-12)
    # Closed form: the -x face is `shift` away; on the +x face (inside the moved box) the
    # distance is min(shift, b/2 - |y|, c/2 - |z|); side faces are off only on a strip of width
    # `shift`, at a mean distance of shift / 2.
    a, b, c = EXTENTS
    s = shift
    plus_x = s - s**2 * (1 / b + 1 / c) + 4 * s**3 / (3 * b * c)
    expected = (b * c * (s + plus_x) + 2 * (a * b + a * c) * s**2 / (2 * a)) / (
        2 * (a * b + b * c + a * c)
    )
    assert dev.mean == pytest.approx(expected, rel=0.03)


def test_centroid_error_analytic(sphere):
    ref = trimesh.creation.box(extents=EXTENTS)
    moved = ref.copy()
    moved.apply_translation([0.003, -0.004, 0.0])
    diag = float(np.linalg.norm(EXTENTS))
    assert centroid_error(ref, moved) == pytest.approx(0.005 / diag, rel=1e-9)
    assert centroid_error(ref, ref) == 0.0
    # Same samples scaled about the sphere's centre: the error is the sampling noise times 0.1.
    big = sphere.copy()
    big.apply_scale(1.1)
    assert centroid_error(sphere, big) < 1e-3
    np.testing.assert_allclose(surface_centroid(sphere, 50000), 0.0, atol=1e-3)


def test_exact_surface_centroid_is_the_area_weighted_mean_and_ignores_the_tessellation():
    # A cone's lateral surface has its centroid at a third of the height (the base disc at 0).
    cone = trimesh.creation.cone(radius=0.05, height=0.12, sections=256)
    r, h = 0.05, 0.12
    lateral, base = np.pi * r * np.hypot(r, h), np.pi * r * r
    z_ref = lateral * (h / 3) / (lateral + base)
    np.testing.assert_allclose(surface_centroid(cone), [0, 0, z_ref], atol=2e-5)
    # Splitting every face keeps the surface, so the exact centroid stays to rounding while the
    # sampled estimate (its samples are drawn by face) moves.
    finer = cone.subdivide()
    np.testing.assert_allclose(surface_centroid(finer), surface_centroid(cone), atol=1e-12)
    sampled = [surface_centroid(m, 5000) for m in (cone, finer)]
    assert np.abs(sampled[0] - sampled[1]).max() > 1e-5
    np.testing.assert_allclose(surface_centroid(cone, 200_000), surface_centroid(cone), atol=5e-4)


def test_rotated_reference_uses_oriented_box():
    ref = trimesh.creation.box(extents=EXTENTS)
    ref.apply_transform(trimesh.transformations.rotation_matrix(0.6, [0.3, 0.2, 1.0]))
    moved = ref.copy()
    moved.apply_translation([0.01, 0.0, 0.0])
    assert centroid_error(ref, moved) == pytest.approx(0.01 / np.linalg.norm(EXTENTS), rel=1e-6)


def test_bad_inputs_raise():
    box = trimesh.creation.box(extents=EXTENTS)
    with pytest.raises(InvalidInputError):
        mesh_deviation(box, np.zeros((3, 3)))
    with pytest.raises(EmptyInputError):
        mesh_deviation(box, trimesh.Trimesh())
    with pytest.raises(ShapeError):
        surface_distance(np.zeros((4, 2)), box)
    with pytest.raises(SymjaxError):
        mesh_deviation(box, box, n_samples=0)
    bad = box.copy()
    bad.vertices[0] = np.nan
    with pytest.raises(InvalidInputError):
        centroid_error(bad, box)


def test_surface_distance_sees_a_mesh_moved_in_place():
    """The AABB tree kept on the mesh is rebuilt when its vertices change."""
    mesh = trimesh.creation.box((0.1, 0.1, 0.1))
    p = np.array([[0.0, 0.0, 0.2]])
    np.testing.assert_allclose(surface_distance(p, mesh), [0.15], atol=1e-12)
    mesh.vertices += [0.0, 0.0, 0.05]
    np.testing.assert_allclose(surface_distance(p, mesh), [0.10], atol=1e-12)


def test_surface_distance_is_exact_on_uneven_triangles():
    """A sphere of small triangles beside a box of large ones (the Delaunay baseline's walls):
    every distance equals the brute-force minimum over all triangles."""
    parts = [trimesh.creation.icosphere(3, 0.03), trimesh.creation.box((0.2, 0.02, 0.2))]
    parts[1].apply_translation([0.1, 0.0, 0.0])
    mesh = trimesh.util.concatenate(parts)
    pts = np.random.default_rng(3).normal(0, 0.06, size=(200, 3))
    tri = mesh.triangles
    cp = trimesh.triangles.closest_point(np.repeat(tri, len(pts), axis=0),
                                         np.tile(pts, (len(tri), 1)))  # fmt: skip
    brute = np.linalg.norm(cp - np.tile(pts, (len(tri), 1)), axis=1).reshape(len(tri), -1).min(0)
    np.testing.assert_allclose(surface_distance(pts, mesh), brute, atol=2e-7)


@pytest.mark.parametrize("kind", ["_FcpwTree", "_IglTree"])
def test_both_closest_face_trees_give_the_exact_distance(kind, monkeypatch):
    """FCPW (float32 tree) and libigl (the fallback where FCPW has no wheel) agree with the
    brute-force minimum over all triangles, and the face returned is at that distance."""
    from symjax.metrics import deviation

    pytest.importorskip("fcpw" if kind == "_FcpwTree" else "igl")
    monkeypatch.setattr(deviation, "_tree_kind", lambda: getattr(deviation, kind))
    mesh = trimesh.creation.icosphere(subdivisions=3, radius=0.05)
    mesh.vertices += np.random.default_rng(0).normal(0, 0.002, mesh.vertices.shape)
    mesh.apply_translation([0.6, -0.3, 0.8])  # float32 needs the vertex-mean shift here
    pts = mesh.centroid + np.random.default_rng(1).normal(0, 0.05, size=(300, 3))
    tri = mesh.triangles
    cp = trimesh.triangles.closest_point(np.repeat(tri, len(pts), axis=0),
                                         np.tile(pts, (len(tri), 1)))  # fmt: skip
    brute = np.linalg.norm(cp - np.tile(pts, (len(tri), 1)), axis=1).reshape(len(tri), -1).min(0)
    d, face = surface_distance(pts, mesh, return_faces=True)
    assert type(mesh.__dict__["_symjax_bvh"]).__name__ == kind
    np.testing.assert_allclose(d, brute, atol=1e-8)
    from symjax.geometry import closest_point_on_triangle

    np.testing.assert_allclose(
        np.linalg.norm(closest_point_on_triangle(pts, tri[face]) - pts, axis=1), d, atol=0
    )
