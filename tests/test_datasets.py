"""The embedded benchmark: objects, symmetry ground truth, stereo simulation, cache and views."""

from __future__ import annotations

import json
import math

import cv2
import numpy as np
import pytest
import trimesh
from test_mesh_rays import nearest_hits

from symjax.datasets import (
    DATASET_IDS,
    GENERATOR_VERSION,
    BenchmarkConfig,
    load_dataset_object,
    render_view,
    render_views,
    symmetry_truth,
    view_names,
)
from symjax.datasets import benchmark as make_benchmark
from symjax.datasets.mesh_symmetry import MeshSymmetryConfig, is_symmetry_plane
from symjax.datasets.preprocess import table_principal_axis
from symjax.datasets.raycast import render_depth, scene_model
from symjax.datasets.render import render_exact
from symjax.datasets.stereo import StereoHead, StereoNoise, outline_bands
from symjax.errors import ConfigError, InvalidInputError, MissingFileError, UnknownNameError
from symjax.metrics import plane_error as metric_plane_error
from symjax.metrics import surface_distance


def plane_error(view, normal, offset):
    """The found plane's error against the view's truth (:func:`symjax.metrics.plane_error`)."""
    return metric_plane_error(normal, offset, **symmetry_truth(view))


# A spread of the benchmark: planar (one plane with a handle, two planes lying), rotational,
# asymmetric, and the largest object; orientation 0 for two of them.
SUBSET = [
    "025_mug/000",
    "025_mug/135",
    "005_tomato_soup_can/090",
    "003_cracker_box_lying/045",
    "011_banana/270",
    "019_pitcher_base/000",
]
SYM = MeshSymmetryConfig(n_verify=3000)
THRESHOLD = SYM.threshold


@pytest.fixture(scope="session")
def cache(tmp_path_factory):
    return tmp_path_factory.mktemp("symjax-cache")


@pytest.fixture(scope="session")
def bench(cache):
    return make_benchmark(SUBSET, cache_dir=cache, seed=0, workers=1)


@pytest.fixture(scope="session")
def views(bench):
    return {v.name: v for v in bench}


def _ray_factor(view, points):
    """|ray| / z per point: a depth error dz moves a point by dz * factor along its ray."""
    xc = np.asarray(view.camera.world_to_camera(points), np.float64)
    return np.linalg.norm(xc, axis=1) / xc[:, 2], xc[:, 2]


# ------------------------------------------------------------------------------------- views --


def test_subset_and_sizes(bench, views):
    assert bench.names == [n for n in view_names() if n in SUBSET]  # canonical order
    for v in views.values():
        assert v.depth.shape == (480, 640)
        # The paper's clouds have 2k-40k points.
        assert 2000 <= len(v.points) <= 40000, (v.name, len(v.points))
        assert v.flying.shape == (len(v.points),)
        assert v.gt_mesh is not None and v.gt_pose.shape == (4, 4)
        # Camera 0.6-1.0 m from the object, 30-50 deg elevation.
        assert 0.6 - 1e-6 <= v.meta["distance_m"] <= 1.0 + 1e-6
        assert 30.0 - 1e-6 <= v.meta["elevation_deg"] <= 50.0 + 1e-6
        # The table is in the frame: most of the image has depth.
        assert (v.depth > 0).mean() > 0.5


def test_points_lie_on_the_surface_within_the_noise_bound(views):
    """Every non-flying point is within the noise model's bound of the ground-truth surface.

    The bound is the disparity bound (truncated noise plus half a quantisation step) turned into
    depth at the point's depth, times |ray| / z (the error is along the viewing ray; the distance
    to the surface is at most that). Flying pixels are flagged and must be few.
    """
    noise, head = StereoNoise(), StereoHead()
    f = math.sqrt(head.fx * head.fy)
    for v in views.values():
        pts = v.points.astype(np.float64)
        factor, z = _ray_factor(v, pts)
        # z is the noisy depth; the bound grows with depth, so evaluate it slightly deeper.
        bound = noise.depth_bound(z * 1.02, f, head.baseline) * factor + 1e-5
        dist = surface_distance(pts, v.gt_mesh, candidates=12)
        ok = ~v.flying
        assert np.all(dist[ok] <= bound[ok]), (v.name, float((dist[ok] - bound[ok]).max()))
        # The bound is tight enough to mean something: the noise does move points.
        assert np.median(dist[ok]) > 1e-5
        assert 0 < v.flying.sum() <= max(noise.flying_min, 0.01 * len(pts)), v.name
        # Flying pixels lie between the object and the background of a neighbouring pixel.
        exact, obj = render_exact(v.gt_mesh, v.camera)
        bg = cv2.dilate(np.where(obj, 0, exact), np.ones((3, 3), np.uint8))
        fz = z[v.flying]
        uv, _ = v.camera.project(pts[v.flying])
        col, row = np.rint(np.asarray(uv)).astype(int).T
        assert np.all(fz >= exact[row, col] + noise.flying_t[0] * noise.flying_min_gap - 1e-4)
        assert np.all(fz <= bg[row, col] + 1e-4)


def test_masks_match_projections(views):
    for v in views.values():
        cam, obs = v.camera, v.observation
        uv, z = cam.project(v.points.astype(np.float64))
        uv, z = np.asarray(uv), np.asarray(z)
        col, row = np.rint(uv[:, 0]).astype(int), np.rint(uv[:, 1]).astype(int)
        # Points are back-projected pixel centres: they project onto them exactly.
        assert np.abs(uv - np.stack([col, row], 1)).max() < 1e-2
        mask = np.asarray(obs.mask)
        depth = np.asarray(obs.depth)
        assert mask[row, col].all()
        np.testing.assert_allclose(depth[row, col], z, rtol=1e-5)
        # One point per depth pixel, and no depth outside the mask.
        assert len(set(zip(row.tolist(), col.tolist(), strict=True))) == len(v.points)
        assert (depth > 0).sum() == len(v.points)
        assert not (depth[~mask] > 0).any()
        # The object's depth equals the full-frame depth on the object.
        np.testing.assert_array_equal(depth[mask], np.where(depth[mask] > 0, v.depth[mask], 0))
        # The mask is the object's exact silhouette (segmentation ground truth): re-render it.
        _, gid = render_depth(scene_model(meshes=[v.gt_mesh]), cam)
        np.testing.assert_array_equal(mask, gid >= 1)
        # Missing depth (grazing angles, border band) is a minority of the mask.
        assert (depth > 0).sum() >= 0.8 * mask.sum()


def test_zero_degrees_means_longest_dimension_parallel_to_the_image_plane(views):
    for name in ["025_mug/000", "019_pitcher_base/000", "025_mug/135"]:
        v = views[name]
        axis = table_principal_axis(v.gt_mesh)
        optical = np.asarray(v.camera.T_world_cam)[:3, 2].copy()
        optical[2] = 0
        optical /= np.linalg.norm(optical)
        # Angle between the long axis and the image plane (i.e. the horizontal view direction).
        ang = math.degrees(math.asin(min(1.0, abs(float(axis @ optical)))))
        expected = min(v.orientation_deg % 180, 180 - v.orientation_deg % 180)
        expected = min(expected, 90.0)
        assert abs(ang - expected) < 0.5, (name, ang, expected)
    # And the long axis is the longest table-projected dimension: the extent along it is the
    # largest over all horizontal directions.
    v = views["019_pitcher_base/000"]
    axis = table_principal_axis(v.gt_mesh)
    xy = np.asarray(v.gt_mesh.vertices)[:, :2]
    along = np.ptp(xy @ axis[:2])
    ortho = np.ptp(xy @ np.array([-axis[1], axis[0]]))
    assert along > ortho


def test_same_seed_gives_identical_data(views, cache):
    obj = load_dataset_object("025_mug", cache_dir=cache)
    a = render_view(obj, 135.0, seed=0)
    b = views["025_mug/135"]  # generated earlier, stored and reloaded from the cache
    for x, y in [
        (a.points, b.points),
        (a.depth, b.depth),
        (a.observation.mask, b.observation.mask),
        (a.observation.depth, b.observation.depth),
        (a.flying, b.flying),
        (a.gt_pose, b.gt_pose),
        (a.camera.T_world_cam, b.camera.T_world_cam),
    ]:
        np.testing.assert_array_equal(np.asarray(x), np.asarray(y))
    c = render_view(obj, 135.0, seed=1)
    assert not np.array_equal(np.asarray(c.camera.T_world_cam), np.asarray(a.camera.T_world_cam))
    assert c.points.shape != a.points.shape or not np.array_equal(c.points, a.points)


# ---------------------------------------------------------------------------------- symmetry --


def test_recorded_symmetry_planes_are_real_symmetries(views):
    """In the world frame, each recorded plane mirrors the posed mesh onto itself.

    The criterion of :func:`is_symmetry_plane` (mean mirrored deviation < 3 mm and 98% of it
    < 1 cm), on fresh surface samples (another seed than the detection's).
    """
    seen = set()

    def check(mesh, n, o):
        return is_symmetry_plane(mesh, n, o, SYM, seed=7)

    for v in views.values():
        seen.add(v.symmetry)
        mesh = v.gt_mesh
        if v.symmetry == "planar":
            assert v.symmetry_planes
            for n, o in v.symmetry_planes:
                assert abs(n[2]) < 1e-9  # perpendicular to the table
                ok, mean, tail = check(mesh, n, o)
                assert ok and mean < THRESHOLD, (v.name, mean, tail)
                # Sanity of the check itself: a plane 25 deg off is not a symmetry.
                c, s = math.cos(math.radians(25)), math.sin(math.radians(25))
                n2 = np.array([c * n[0] - s * n[1], s * n[0] + c * n[1], 0.0])
                p = mesh.bounds.mean(0)
                o2 = float(n2 @ (p - (n @ p - o) * n))
                assert not check(mesh, n2, o2)[0], v.name
        elif v.symmetry == "rotational":
            a, d = v.symmetry_axis
            assert np.allclose(d, [0, 0, 1])
            for ang in (10.0, 77.0, 133.0):
                n = np.array([math.cos(math.radians(ang)), math.sin(math.radians(ang)), 0.0])
                assert check(mesh, n, float(n @ a))[0], (v.name, ang)
            ((n, o),) = v.symmetry_planes
            assert check(mesh, n, o)[0]
            # ... but not a plane 1 cm off the axis.
            assert not check(mesh, n, o + 0.01)[0]
        else:
            assert v.symmetry == "none" and v.symmetry_planes == []
            # No vertical plane through the centre is a symmetry (coarse check, 5 deg steps).
            c = mesh.bounds.mean(0)
            for ang in range(0, 180, 5):
                n = np.array([math.cos(math.radians(ang)), math.sin(math.radians(ang)), 0.0])
                assert not check(mesh, n, float(n @ c))[0], (v.name, ang)
    assert seen == {"planar", "rotational", "none"}


# Symmetry of every data set's object (planes per data set; README table).
EXPECTED_SYMMETRY = {
    "003_cracker_box": ("planar", 2),
    "005_tomato_soup_can": ("rotational", 0),
    "006_mustard_bottle": ("planar", 2),
    "021_bleach_cleanser": ("planar", 1),
    "004_sugar_box": ("planar", 2),
    "022_windex_bottle": ("none", 0),
    "025_mug": ("planar", 1),
    "065-a_cups": ("rotational", 0),
    "065-f_cups": ("rotational", 0),
    "019_pitcher_base": ("planar", 1),
    "035_power_drill": ("none", 0),
    "011_banana": ("none", 0),
    "003_cracker_box_lying": ("planar", 2),
    "005_tomato_soup_can_lying": ("planar", 2),
    "006_mustard_bottle_lying": ("planar", 1),
    "021_bleach_cleanser_lying": ("planar", 1),
}


@pytest.mark.slow
def test_every_dataset_symmetry_is_verified(cache):
    """All 16 preprocessed objects: on the table, and their recorded symmetry verified anew."""
    assert set(EXPECTED_SYMMETRY) == set(DATASET_IDS)
    for ds in DATASET_IDS:
        obj = load_dataset_object(ds, cache_dir=cache)
        mesh, sym = obj.mesh, obj.symmetry
        assert abs(mesh.bounds[0, 2]) < 1e-9, ds
        assert (sym.kind, len(sym.planes)) == EXPECTED_SYMMETRY[ds], ds
        for n, o in sym.planes:
            assert is_symmetry_plane(mesh, n, o, SYM, seed=11)[0], ds
        if sym.kind == "rotational":
            a = np.array([*sym.axis_xy, 0.0])
            for ang in (20.0, 95.0, 160.0):
                n = np.array([math.cos(math.radians(ang)), math.sin(math.radians(ang)), 0.0])
                assert is_symmetry_plane(mesh, n, float(n @ a), SYM, seed=11)[0], (ds, ang)
        # Canonical frame: the longest table-projected dimension is +x.
        axis = table_principal_axis(mesh)
        assert abs(axis[0]) > 0.9999, (ds, axis)


def test_symmetry_kinds_of_the_objects(views):
    assert views["025_mug/000"].symmetry == "planar"
    assert len(views["025_mug/000"].symmetry_planes) == 1  # the handle breaks the rotation
    assert views["005_tomato_soup_can/090"].symmetry == "rotational"
    assert len(views["003_cracker_box_lying/045"].symmetry_planes) == 2
    assert views["011_banana/270"].symmetry == "none"


def test_plane_error(views):
    v = views["003_cracker_box_lying/045"]
    n, o = v.symmetry_planes[0]
    assert plane_error(v, n, o) == pytest.approx((0.0, 0.0), abs=1e-6)
    assert plane_error(v, -n, -o) == pytest.approx((0.0, 0.0), abs=1e-6)
    ang, off = plane_error(v, n, o + 0.01)
    assert ang == pytest.approx(0.0, abs=1e-6) and off == pytest.approx(0.01, abs=1e-9)
    # Rotational: any vertical plane through the axis is exact; a shifted one is not.
    r = views["005_tomato_soup_can/090"]
    a, _ = r.symmetry_axis
    m = np.array([math.cos(1.0), math.sin(1.0), 0.0])
    assert plane_error(r, m, float(m @ a)) == pytest.approx((0.0, 0.0), abs=1e-6)
    assert plane_error(r, m, float(m @ a) + 0.02)[1] == pytest.approx(0.02, abs=1e-9)
    tilted = np.array([math.cos(1.0), math.sin(1.0), 0.2])
    assert plane_error(r, tilted, 0.0)[0] > 10
    assert all(math.isnan(x) for x in plane_error(views["011_banana/270"], m, 0.0))
    with pytest.raises(InvalidInputError):
        plane_error(v, [0.0, 0.0, 0.0], 0.0)


# ---------------------------------------------------------------------- ray casting & objects --


def test_ray_casting_hits_the_mesh_triangles_not_the_convex_hull(views):
    """The mug's handle hole is seen through: MuJoCo rays use the triangles (collision uses the
    hull). Compared with a brute-force ray-triangle test on the same rays."""
    v = views["025_mug/000"]  # handle along the image x axis, hole facing the camera
    mesh, cam = v.gt_mesh, v.camera
    hull = mesh.convex_hull
    _, gid = render_depth(scene_model(meshes=[mesh]), cam)
    _, gid_hull = render_depth(scene_model(meshes=[hull]), cam)
    hole = (gid_hull >= 1) & (gid < 1)
    assert hole.sum() > 50  # the hole and the concavities are visible
    rows, cols = np.nonzero(hole)
    pick = np.linspace(0, len(rows) - 1, 40).astype(int)
    K, T = np.asarray(cam.K), np.asarray(cam.T_world_cam)
    dirs_cam = np.stack(
        [(cols[pick] - K[0, 2]) / K[0, 0], (rows[pick] - K[1, 2]) / K[1, 1], np.ones(len(pick))], 1
    )
    dirs = dirs_cam @ T[:3, :3].T
    assert np.all(np.isinf(nearest_hits(T[:3, 3], dirs, np.asarray(mesh.triangles), t_min=0.0)))
    # And on object pixels the brute-force depth matches the rendered one.
    depth, gid = render_depth(scene_model(meshes=[mesh]), cam)
    rows, cols = np.nonzero(gid >= 1)
    pick = np.linspace(0, len(rows) - 1, 30).astype(int)
    dirs_cam = np.stack(
        [(cols[pick] - K[0, 2]) / K[0, 0], (rows[pick] - K[1, 2]) / K[1, 1], np.ones(len(pick))], 1
    )
    t = nearest_hits(T[:3, 3], dirs_cam @ T[:3, :3].T, np.asarray(mesh.triangles), t_min=0.0)
    np.testing.assert_allclose(t, depth[rows[pick], cols[pick]], atol=1e-5)


def test_preprocessed_objects_rest_on_the_table(views):
    for v in views.values():
        b = v.gt_mesh.bounds
        assert abs(b[0, 2]) < 1e-9
        assert v.gt_mesh.is_watertight


def test_custom_mesh_path_and_errors(tmp_path):
    box = trimesh.creation.box((0.12, 0.06, 0.1))
    path = tmp_path / "my_box.stl"
    box.export(path)
    cfg = BenchmarkConfig(orientations_deg=(30.0,))
    (view,) = render_views(path, orientations_deg=(30.0,), seed=2, config=cfg)
    assert view.dataset == "my_box" and view.symmetry == "planar"
    assert len(view.symmetry_planes) == 2
    assert 2000 <= len(view.points)
    # The box's long side (x) is 30 deg from the image plane.
    axis = table_principal_axis(view.gt_mesh)
    assert abs(math.degrees(math.atan2(axis[1], axis[0])) % 180 - 30) < 0.5
    with pytest.raises(MissingFileError):
        render_views(tmp_path / "missing.stl")
    with pytest.raises(UnknownNameError, match="003_cracker_box"):
        render_views("no_such_object")
    with pytest.raises(UnknownNameError, match="025_mug"):
        make_benchmark("no_such_dataset", cache_dir=tmp_path)
    with pytest.raises(ConfigError):
        StereoHead(distance_range=(1.0, 0.5))
    with pytest.raises(ConfigError):
        StereoNoise(grazing_deg=100)


# --------------------------------------------------------------------------------- the cache --


def test_cache_is_reused_and_regenerated_on_version_change(cache, bench, monkeypatch):
    index_path = bench.folder / "index.json"
    index = json.loads(index_path.read_text())
    assert index["generator_version"] == GENERATOR_VERSION
    assert set(index["views"]) == set(SUBSET)
    f = bench.folder / index["views"]["025_mug/000"]["file"]
    mtime = f.stat().st_mtime_ns
    again = make_benchmark(["025_mug/000"], cache_dir=cache, workers=1)
    assert f.stat().st_mtime_ns == mtime  # reused, not rewritten
    assert again.names == ["025_mug/000"]
    before = again[0].points
    # No temporary files left behind by the atomic writes.
    assert not list(bench.folder.glob("*.tmp"))
    # A new generator version uses a new folder (old data is never mixed in).
    from symjax.datasets import render as bm

    monkeypatch.setattr(bm, "GENERATOR_VERSION", GENERATOR_VERSION + 1)
    assert BenchmarkConfig().key() != bench.folder.name.split("-")[-1]
    # An index written by another version is ignored.
    index["generator_version"] = -1
    index_path.write_text(json.dumps(index))
    monkeypatch.setattr(bm, "GENERATOR_VERSION", GENERATOR_VERSION)
    regen = make_benchmark(["025_mug/000"], cache_dir=cache, workers=1)
    assert f.stat().st_mtime_ns != mtime
    assert json.loads(index_path.read_text())["generator_version"] == GENERATOR_VERSION
    np.testing.assert_array_equal(regen[0].points, before)  # deterministic


def test_default_cache_dir_env(monkeypatch, tmp_path):
    from symjax.datasets.collection import default_cache_dir

    monkeypatch.setenv("SYMJAX_CACHE", str(tmp_path))
    assert default_cache_dir() == tmp_path / f"benchmark-v{GENERATOR_VERSION}"


def test_view_names_cover_128_views():
    names = view_names()
    assert len(names) == 128 == len(set(names))
    assert len(DATASET_IDS) == 16


def test_outline_bands():
    m = np.zeros((7, 7), bool)
    m[2:5, 2:5] = True
    inner, outer = outline_bands(m)
    assert inner.sum() == 8 and outer.sum() == 12
    assert not (inner & ~m).any() and not (outer & m).any()


def test_real_views_use_the_same_type(shared_dir):
    """The paper's KTH layout loads into the same View type (no ground truth: symmetry unknown)."""
    from symjax.datasets.view import View
    from symjax.io import load_kth_view

    view = View.from_kth(load_kth_view(shared_dir / "kth_demo" / "segment_000.crd"))
    assert view.orientation_deg == 0.0 and view.source == "kth"
    assert view.gt_mesh is None and view.symmetry_planes is None and view.symmetry == "unknown"
    assert len(view.points) > 1000 and view.depth.shape == view.mask.shape
    with pytest.raises(InvalidInputError, match="no known symmetry"):
        plane_error(view, [1.0, 0.0, 0.0], 0.0)


@pytest.mark.slow
def test_all_128_views_with_a_process_pool(cache):
    """The full benchmark through the process pool: 128 views, clouds of 2k-40k points."""
    bench = make_benchmark(cache_dir=cache, workers=2)
    assert len(bench) == 128 and bench.names == view_names()
    assert len(bench.datasets) == 16
    index = json.loads((bench.folder / "index.json").read_text())
    assert len(index["views"]) == 128
    sizes = [v["n_points"] for v in index["views"].values()]
    assert 2000 <= min(sizes) and max(sizes) <= 40000, (min(sizes), max(sizes))
    # Spot-load a few views: what the index says is what the files hold.
    for name in ("011_banana/315", "021_bleach_cleanser_lying/180"):
        assert len(bench[name].points) == index["views"][name]["n_points"]
    # A view rendered in a worker process equals the same view rendered here.
    here = render_view(load_dataset_object("011_banana", cache_dir=cache), 315.0, seed=0)
    np.testing.assert_array_equal(here.points, bench["011_banana/315"].points)
    np.testing.assert_array_equal(here.depth, bench["011_banana/315"].depth)


def test_true_mesh_in_the_world_frame(views, cache):
    import dataclasses

    v = views["025_mug/135"]
    bare = dataclasses.replace(v, gt_mesh=None)  # as read without its object model
    m = bare.true_mesh(cache)
    np.testing.assert_allclose(m.vertices, v.gt_mesh.vertices, atol=1e-9)
    assert v.true_mesh() is v.gt_mesh
    # The observed points lie on it.
    d = surface_distance(v.points[::20], m)
    assert np.median(d) < 0.005
    real = dataclasses.replace(v, gt_mesh=None, gt_pose=None, source="real")
    with pytest.raises(InvalidInputError, match="no ground truth"):
        real.true_mesh()


def test_the_oriented_diagonal_is_kept_with_the_cached_object(tmp_path, monkeypatch):
    import symjax.metrics as metrics
    from symjax.datasets.objects import OBJECTS_VERSION, _read_object, load_object

    mesh = trimesh.creation.box((0.1, 0.06, 0.2))
    obj = load_object(mesh, dataset="box", cache_dir=tmp_path)
    want = metrics.oriented_diagonal(obj.mesh)
    (path,) = (tmp_path / f"objects-v{OBJECTS_VERSION}").glob("box-*.npz")
    calls = []
    monkeypatch.setattr(metrics, "oriented_diagonal", lambda m: calls.append(1) or -1.0)
    again = load_object(mesh, dataset="box", cache_dir=tmp_path)
    assert again.oriented_diagonal == want and calls == []  # read, not computed
    monkeypatch.undo()
    # A file written before the diagonal was kept gets it on its first read.
    with np.load(path) as z:
        arrays = {k: z[k] for k in z.files}
    meta = json.loads(str(arrays["meta"]))
    del meta["oriented_diagonal"]
    arrays["meta"] = np.array(json.dumps(meta))
    np.savez_compressed(path, **arrays)
    assert "oriented_diagonal" not in _read_object(path).__dict__
    assert load_object(mesh, dataset="box", cache_dir=tmp_path).oriented_diagonal == want
    assert _read_object(path).__dict__["oriented_diagonal"] == want
