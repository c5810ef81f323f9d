"""Normals, Poisson reconstruction and the Delaunay baseline (paper Sections II-B, V-A.2)."""

from __future__ import annotations

import dataclasses
from types import SimpleNamespace

import _scenes
import numpy as np
import pytest
import trimesh

from symjax.errors import (
    ConfigError,
    DegenerateGeometryError,
    EmptyInputError,
    InvalidInputError,
    ShapeError,
    SymjaxError,
)
from symjax.execution import ExecutionConfig
from symjax.metrics import mesh_deviation, surface_distance
from symjax.surface import (
    DelaunayConfig,
    NormalsConfig,
    PoissonConfig,
    delaunay_mesh,
    estimate_normals,
    oriented_completion,
    oriented_observation,
    outlier_mask,
    poisson_reconstruct,
    poisson_reconstruct_batch,
)
from symjax.symmetry import reflect

N_POINTS = 20000
CENTRE = np.array([0.1, -0.2, 0.3])
BOX = np.array([0.12, 0.07, 0.10])


def sphere_samples(n: int, radius: float, seed: int = 0):
    v = np.random.default_rng(seed).normal(size=(n, 3))
    v /= np.linalg.norm(v, axis=1, keepdims=True)
    return CENTRE + radius * v, v


def sphere_mesh(radius: float):
    m = trimesh.creation.icosphere(subdivisions=5, radius=radius)
    m.apply_translation(CENTRE)
    return m


@pytest.fixture(scope="session")
def box_data():
    box = trimesh.creation.box(extents=BOX)
    box.apply_translation(CENTRE)
    pts, face = trimesh.sample.sample_surface(box, N_POINTS, seed=1)
    return box, np.asarray(pts), box.face_normals[face]


@pytest.fixture(scope="session")
def meshes(box_data):
    """Poisson meshes of the sphere and box at both depths, reused by several tests."""
    box, bp, bn = box_data
    out = {}
    for depth in (5, 7):
        cfg = PoissonConfig(depth=depth)
        for r in (0.05, 0.02):
            p, n = sphere_samples(N_POINTS, r)
            out["sphere", r, depth] = (sphere_mesh(r), poisson_reconstruct(p, n, config=cfg))
        out["box", depth] = (box, poisson_reconstruct(bp, bn, config=cfg))
    return out


# ---------------------------------------------------------------------------------------------
# Poisson


@pytest.mark.parametrize("depth,tol", [(5, 0.003), (7, 0.001)])
@pytest.mark.parametrize("shape", ["sphere5", "sphere2", "box"])
def test_poisson_accuracy(meshes, shape, depth, tol):
    key = (
        ("box", depth)
        if shape == "box"
        else ("sphere", 0.05 if shape == "sphere5" else 0.02, depth)
    )
    ref, mesh = meshes[key]
    assert mesh.is_watertight and mesh.is_winding_consistent
    assert mesh.volume > 0
    dev = mesh_deviation(ref, mesh, n_samples=10000)
    back = mesh_deviation(mesh, ref, n_samples=10000)
    assert dev.mean <= tol and back.mean <= tol, (dev.mean, back.mean)
    assert mesh.volume == pytest.approx(ref.volume, rel=0.03 if depth == 7 else 0.1)


def test_poisson_weights_drop_zero_weight_points():
    p1, n1 = sphere_samples(4000, 0.03, seed=1)
    p2, n2 = sphere_samples(4000, 0.03, seed=2)
    p2 = p2 + np.array([0.1, 0.0, 0.0])
    pts, nrm = np.concatenate([p1, p2]), np.concatenate([n1, n2])
    w = np.concatenate([np.ones(4000), np.zeros(4000)])
    cfg = PoissonConfig(depth=7)
    mesh = poisson_reconstruct(pts, nrm, w, config=cfg)
    assert mesh.is_watertight
    assert np.linalg.norm(mesh.centroid - CENTRE) < 1e-3
    assert mesh_deviation(sphere_mesh(0.03), mesh, n_samples=5000).mean < 1e-3
    # Without weights both spheres are meshed, and both kept (each is far more than 5 % of
    # the other); keeping the largest component alone leaves one of them.
    ball = 4 / 3 * np.pi * 0.03**3
    both = poisson_reconstruct(pts, nrm, w, config=dataclasses.replace(cfg, use_weights=False))
    assert both.volume == pytest.approx(2 * ball, rel=0.05) and len(both.split()) == 2
    one = dataclasses.replace(cfg, use_weights=False, min_component=1.0)
    assert poisson_reconstruct(pts, nrm, w, config=one).volume == pytest.approx(ball, rel=0.05)


def test_poisson_batch_matches_single(box_data, strict_ranks):
    _, bp, bn = box_data
    p1, n1 = sphere_samples(3000, 0.05, seed=4)
    cfg = PoissonConfig(depth=5)
    views = [(p1, n1, None), (bp[:5000], bn[:5000], np.ones(5000)), (p1 + 0.3, n1, None)]
    batch = poisson_reconstruct_batch(views, cfg, ExecutionConfig(poisson_chunk_views=2))
    assert len(batch) == 3
    for (p, n, w), mb in zip(views, batch, strict=True):
        single = poisson_reconstruct(p, n, w, config=cfg)
        assert mb.is_watertight
        np.testing.assert_allclose(mb.bounds, single.bounds, atol=1e-5)
        assert mb.volume == pytest.approx(single.volume, rel=1e-4)
    np.testing.assert_allclose(batch[2].centroid - batch[0].centroid, 0.3, atol=1e-4)


def test_poisson_open_sheet_still_closed(strict_ranks):
    # A hemisphere only (a partial view): the surface must still come out closed.
    p, n = sphere_samples(4000, 0.05, seed=3)
    keep = n[:, 2] > 0
    mesh = poisson_reconstruct(p[keep], n[keep], config=PoissonConfig(depth=5))
    assert mesh.is_watertight and mesh.volume > 0


def test_poisson_degenerate_inputs_raise():
    cfg = PoissonConfig(depth=5)
    p, n = sphere_samples(500, 0.05)
    t = np.linspace(0, 1, 100)[:, None]
    with pytest.raises(DegenerateGeometryError):  # collinear
        poisson_reconstruct(
            t * np.array([1.0, 2.0, 3.0]), np.tile([0.0, 0, 1], (100, 1)), config=cfg
        )
    plane = np.random.default_rng(0).uniform(size=(100, 3)) * np.array([1, 1, 0])
    with pytest.raises(DegenerateGeometryError):  # coplanar
        poisson_reconstruct(plane, np.tile([0.0, 0, 1], (100, 1)), config=cfg)
    with pytest.raises(EmptyInputError):
        poisson_reconstruct(p[:19], n[:19], config=cfg)
    bad = n.copy()
    bad[7] = np.nan
    with pytest.raises(DegenerateGeometryError):
        poisson_reconstruct(p, bad, config=cfg)
    bad[7] = 0.0
    with pytest.raises(DegenerateGeometryError):
        poisson_reconstruct(p, bad, config=cfg)
    with pytest.raises(ShapeError):
        poisson_reconstruct(p, n[:, :2], config=cfg)
    with pytest.raises(SymjaxError):
        poisson_reconstruct(p, n, np.zeros(len(p)), config=cfg)
    with pytest.raises(SymjaxError):
        poisson_reconstruct(p, n, -np.ones(len(p)), config=cfg)
    with pytest.raises(DegenerateGeometryError, match="inside-out"):
        poisson_reconstruct(p, -n, config=PoissonConfig(depth=5, thin_shell=0))


@pytest.mark.parametrize(
    "kwargs",
    [{"depth": 4.0}, {"depth": 9}, {"padding": 1.0}, {"smoothing": -1}, {"min_points": 2}],
)
def test_poisson_config_validation(kwargs):
    with pytest.raises(ConfigError):
        PoissonConfig(**kwargs)


def test_config_validation_other():
    with pytest.raises(ConfigError):
        NormalsConfig(k=2)
    with pytest.raises(ConfigError):
        DelaunayConfig(n_samples=3)
    with pytest.raises(SymjaxError):
        poisson_reconstruct(np.zeros((30, 3)), np.zeros((30, 3)), config=NormalsConfig())


# ---------------------------------------------------------------------------------------------
# Normals


def test_normals_of_plane_are_exact_and_face_viewpoint():
    rng = np.random.default_rng(0)
    normal = np.array([0.3, -0.2, 0.9])
    normal /= np.linalg.norm(normal)
    u = np.cross(normal, [1.0, 0, 0])
    u /= np.linalg.norm(u)
    v = np.cross(normal, u)
    ab = rng.uniform(-0.05, 0.05, size=(2000, 2))
    pts = 0.2 + ab[:, :1] * u + ab[:, 1:] * v
    viewpoint = 0.2 + 0.5 * normal + np.array([0.05, 0.0, 0.0])
    got = estimate_normals(pts, viewpoint)
    np.testing.assert_allclose(got @ normal, 1.0, atol=1e-9)
    got = estimate_normals(pts, 0.2 - 0.5 * normal)
    np.testing.assert_allclose(got @ normal, -1.0, atol=1e-9)


def test_normals_of_cylinder_radial_and_consistent():
    rng = np.random.default_rng(1)
    r = 0.035
    phi = rng.uniform(-np.pi / 2, np.pi / 2, 4000)  # the half that faces +x
    z = rng.uniform(0, 0.12, 4000)
    pts = np.stack([r * np.cos(phi), r * np.sin(phi), z], axis=1)
    got = estimate_normals(pts, np.array([1.0, 0.0, 0.06]), NormalsConfig(k=10))
    radial = np.stack([np.cos(phi), np.sin(phi), np.zeros_like(phi)], axis=1)
    cos = np.sum(got * radial, axis=1)
    assert np.all(cos > 0.98), cos.min()
    assert np.median(cos) > 0.999


def test_outlier_mask_drops_far_points():
    p, _ = sphere_samples(3000, 0.05)
    far = CENTRE + np.array([[0.3, 0, 0], [0, 0.4, 0], [0, 0, -0.5]])
    keep = outlier_mask(np.concatenate([p, far]))
    assert not keep[-3:].any()
    assert keep[:-3].mean() > 0.97


@pytest.fixture(scope="session")
def cylinder_view():
    obs, _ = _scenes.view("cylinder", 0.0)
    return obs


def fake_completion(obs):
    """A symmetry result whose plane passes through the cylinder axis, facing away from the
    camera (what the search finds for this object)."""
    pts = obs.valid_points()
    d = np.asarray(obs.camera.position)[:2]
    normal = -np.array([d[0], d[1], 0.0]) / np.linalg.norm(d)
    mirrored = np.asarray(reflect(pts, normal, 0.0))
    ones = np.ones(len(pts), bool)
    plaus = np.full(len(pts), 0.8)
    return SimpleNamespace(
        points=pts,
        mirrored=mirrored,
        normal=normal,
        offset=0.0,
        completed_points=np.concatenate([pts, mirrored]),
        completed_valid=np.concatenate([ones, ones]),
        completed_plausibility=np.concatenate([np.ones(len(pts)), plaus]),
    )


def test_oriented_completion_normals_point_out_of_cylinder(cylinder_view):
    op = oriented_completion(fake_completion(cylinder_view), cylinder_view.camera)
    assert op.mirrored.sum() > 0.3 * len(op) and (~op.mirrored).sum() > 0.3 * len(op)
    np.testing.assert_allclose(op.weights[op.mirrored], 0.8)
    side = op.points[:, 2] < 0.115  # lateral surface, away from the top cap's rim
    radial = op.points[:, :2] / np.linalg.norm(op.points[:, :2], axis=1, keepdims=True)
    cos = np.sum(op.normals[side, :2] * radial[side], axis=1)
    # Both halves (observed and mirrored) point out of the object.
    assert np.mean(cos > 0.9) > 0.97
    top = (op.points[:, 2] > 0.1199) & (np.linalg.norm(op.points[:, :2], axis=1) < 0.03)
    assert np.mean(op.normals[top, 2] > 0.95) > 0.97


def test_completion_to_watertight_mesh(cylinder_view):
    op = oriented_completion(fake_completion(cylinder_view), cylinder_view.camera)
    mesh = poisson_reconstruct(op.points, op.normals, op.weights, PoissonConfig(depth=7))
    ref = trimesh.creation.cylinder(radius=0.035, height=0.12, sections=128)
    ref.apply_translation([0, 0, 0.06])
    assert mesh.is_watertight
    # The bottom is unseen (it stands on the table): Poisson closes it, roughly.
    assert mesh_deviation(ref, mesh, n_samples=5000).percentiles[50] < 0.002


# ---------------------------------------------------------------------------------------------
# Delaunay baseline


@pytest.mark.parametrize(
    "kind,yaw", [("box", 0.0), ("box", 0.7), ("cylinder", 0.3), ("bottle", 1.2)]
)
def test_delaunay_baseline_watertight(kind, yaw):
    obs, _ = _scenes.view(kind, yaw)
    mesh = delaunay_mesh(obs.valid_points(), obs.camera)
    assert mesh.is_watertight and mesh.is_winding_consistent and mesh.volume > 0
    # The front sheet is built on 500 samples of the visible points.
    pts = obs.valid_points()
    assert len(mesh.vertices) <= 2 * 500
    # Every visible point is close to the mesh (the sheet interpolates them).
    dist = surface_distance(pts[::20], mesh)
    assert np.percentile(dist, 95) < 0.004
    # The mesh stays within the object's depth range seen from the camera.
    _, z = obs.camera.project(np.asarray(mesh.vertices))
    _, zp = obs.camera.project(pts)
    assert np.min(z) >= np.min(zp) - 1e-9 and np.max(z) <= np.max(zp) + 0.0021


def test_delaunay_degenerate_inputs_raise(cylinder_view):
    cam = cylinder_view.camera
    pts = cylinder_view.valid_points()
    with pytest.raises(EmptyInputError):
        delaunay_mesh(pts[:10], cam)
    line = np.linspace(0, 1, 50)[:, None] * np.array([0.01, 0.02, 0.0]) + np.array([0, 0, 0.05])
    with pytest.raises(DegenerateGeometryError):
        delaunay_mesh(line, cam)
    with pytest.raises(SymjaxError):
        delaunay_mesh(pts, cam, DelaunayConfig(max_edge_m=1e-6))


# ---------------------------------------------------------------------------------------------
# End to end: symmetry search -> completed cloud -> mesh, against the paper's baseline


def _box_truth(yaw: float) -> trimesh.Trimesh:
    m = trimesh.creation.box(extents=(0.12, 0.07, 0.10))
    m.apply_translation([0, 0, 0.05])
    m.apply_transform(trimesh.transformations.rotation_matrix(yaw, [0, 0, 1]))
    return m


def test_symmetry_completion_beats_delaunay_baseline():
    from symjax.metrics import centroid_error
    from symjax.symmetry import search, search_batch

    obs, _ = _scenes.view("box", 0.5)
    gt = _box_truth(0.5)
    op = oriented_completion(search(obs), obs.camera)
    mirrored = poisson_reconstruct(op.points, op.normals, op.weights, PoissonConfig(depth=7))
    baseline = delaunay_mesh(obs.valid_points(), obs.camera)
    assert mirrored.is_watertight and baseline.is_watertight
    dev_mir = mesh_deviation(gt, mirrored, n_samples=5000).mean
    dev_del = mesh_deviation(gt, baseline, n_samples=5000).mean
    # Paper Fig. 10: the mirrored meshes deviate less than the Delaunay ones.
    assert dev_mir < 0.005 and dev_mir < 0.7 * dev_del, (dev_mir, dev_del)
    assert centroid_error(gt, mirrored) < 0.5 * centroid_error(gt, baseline)

    obs2, _ = _scenes.view("cylinder", 0.2, azimuth=1.0)
    results = search_batch([obs, obs2])
    ops = [oriented_completion(results[i], o.camera) for i, o in enumerate([obs, obs2])]
    meshes = poisson_reconstruct_batch(ops, PoissonConfig(depth=5))
    assert len(meshes) == 2 and all(m.is_watertight for m in meshes)
    assert mesh_deviation(gt, meshes[0], n_samples=5000).mean < 0.006


def test_an_observed_cloud_alone_meshes_with_poisson():
    """The baseline "observed points only": normals face the camera, Poisson closes the blob."""
    rng = np.random.default_rng(4)
    th = rng.uniform(-np.pi / 2, np.pi / 2, 3000)  # the half of a cylinder facing the camera
    z = rng.uniform(0.0, 0.12, 3000)
    pts = np.c_[0.6 - 0.035 * np.cos(th), 0.035 * np.sin(th), z]
    cam = np.array([0.0, 0.0, 0.5])
    op = oriented_observation(pts, cam)
    assert len(op) > 2900 and not op.mirrored.any()
    assert np.all(np.einsum("ij,ij->i", op.normals, cam - op.points) > 0)
    mesh = poisson_reconstruct(op.points, op.normals, op.weights, PoissonConfig(depth=5))
    assert mesh.is_watertight
    d = np.abs(np.hypot(mesh.vertices[:, 0] - 0.6, mesh.vertices[:, 1]) - 0.035)
    front = mesh.vertices[:, 0] < 0.59
    assert np.median(d[front]) < 0.004
    with pytest.raises(ShapeError, match="camera"):
        oriented_observation(pts, np.zeros(2))


def test_completion_is_cut_and_closed_at_the_table():
    """Points of a can standing on the table (side and top, no bottom): the Poisson surface
    bulges under the table unless cut there; cut, it is closed by a flat bottom on the table."""
    from symjax.table import TablePlane

    rng = np.random.default_rng(5)
    th = rng.uniform(0, 2 * np.pi, 4000)
    z = rng.uniform(0.0, 0.12, 4000)
    side = np.c_[0.035 * np.cos(th), 0.035 * np.sin(th), z]
    r = 0.035 * np.sqrt(rng.uniform(0, 1, 800))
    a = rng.uniform(0, 2 * np.pi, 800)
    top = np.c_[r * np.cos(a), r * np.sin(a), np.full(800, 0.12)]
    pts = np.concatenate([side, top]) + [0.6, 0.1, 0.0]
    nrm = np.concatenate([np.c_[np.cos(th), np.sin(th), np.zeros(4000)],
                          np.tile([0.0, 0.0, 1.0], (800, 1))])  # fmt: skip
    cfg = PoissonConfig(depth=6)
    free = poisson_reconstruct(pts, nrm, config=cfg)
    assert free.vertices[:, 2].min() < -0.002  # the defect: it reaches under the table
    table = TablePlane.horizontal(0.0)
    cut = poisson_reconstruct(pts, nrm, config=cfg, table=table)
    assert cut.is_watertight and cut.is_winding_consistent and cut.volume > 0
    assert cut.vertices[:, 2].min() > -1e-4
    bottom = cut.vertices[np.abs(cut.vertices[:, 2]) < 1e-4]
    assert np.ptp(bottom[:, 0]) > 0.05  # a flat disc on the table closes it
    vol = np.pi * 0.035**2 * 0.12
    assert abs(cut.volume - vol) < 0.15 * vol
    # The batch cuts each view at its own table.
    a, b = poisson_reconstruct_batch([(pts, nrm), (pts, nrm)], cfg,
                                     tables=[table, TablePlane.horizontal(-0.05)])  # fmt: skip
    np.testing.assert_allclose(a.vertices, cut.vertices, atol=1e-6)
    assert b.vertices[:, 2].min() < -0.002
    with pytest.raises(InvalidInputError, match="tables"):
        poisson_reconstruct_batch([(pts, nrm)], cfg, tables=[table, table])


def test_an_open_bowl_seen_from_inside_meshes_as_a_wall():
    """The inner surface of a bowl (normals into the cavity) gave an inside-out indicator and no
    mesh; it is now solved as a wall 3 mm thick (depth 7) with the cavity left open."""
    from symjax.grasp import inside_mesh

    rng = np.random.default_rng(0)
    u = rng.normal(size=(6000, 3))
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    h = u[u[:, 2] < 0.2]  # a 5 cm bowl, open at the top
    c = np.array([0.5, 0.0, 0.05])
    with pytest.raises(DegenerateGeometryError, match="inside-out"):
        poisson_reconstruct(0.05 * h + c, -h, config=PoissonConfig(depth=6, thin_shell=0))
    m = poisson_reconstruct(0.05 * h + c, -h, config=PoissonConfig(depth=7))
    assert m.is_watertight and m.volume > 0
    r = np.linalg.norm(m.vertices - c, axis=1)
    assert r.min() > 0.049 and r.max() < 0.054
    t = m.metadata["thin_shell_m"]
    area = 2 * np.pi * 0.05**2 * 1.2  # the cap below z = 0.2 r
    assert abs(m.volume - area * t) < 0.15 * area * t
    assert not inside_mesh(c[None], m)[0]  # the cavity stays open
    (b,) = poisson_reconstruct_batch([(0.05 * h + c, -h)], PoissonConfig(depth=7))
    np.testing.assert_allclose(b.vertices, m.vertices, atol=1e-5)


def test_a_scanned_bowl_seen_from_above_gives_a_mesh(tmp_path):
    """YCB's bowl, rendered from the head camera, completed by symmetry: Poisson used to raise
    "inside-out" on it; now a closed mesh standing on the table, none of it below."""
    from symjax.datasets.objects import load_object
    from symjax.datasets.render import render_view
    from symjax.symmetry import search_batch

    view = render_view(load_object("024_bowl", cache_dir=tmp_path), 90.0, seed=0)
    res = search_batch([view.observation])[0]
    op = oriented_completion(res, view.camera)
    with pytest.raises(DegenerateGeometryError, match="inside-out"):
        poisson_reconstruct(op.points, op.normals, op.weights, PoissonConfig(depth=5, thin_shell=0))
    mesh = poisson_reconstruct(op.points, op.normals, op.weights, PoissonConfig(depth=5),
                               table=view.observation.table)  # fmt: skip
    assert mesh.is_watertight and mesh.volume > 0
    assert mesh.vertices[:, 2].min() > -1e-4
    truth = view.true_mesh()
    assert np.all(np.abs(mesh.extents[:2] - truth.extents[:2]) < 0.03)
