"""Loaders and writers of symjax.io: round trips, the KTH view, and bad files."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest

from symjax.camera import Camera
from symjax.errors import FileFormatError, MissingFileError, SymjaxError
from symjax.io import (
    cloud_observation,
    load_camera_json,
    load_depth_frame,
    load_kth_directory,
    load_kth_view,
    read_depth_image,
    read_kth_segment,
    read_mesh,
    read_point_cloud,
    write_camera_json,
    write_depth_png,
    write_mesh,
    write_point_cloud,
)
from symjax.table import TablePlane

DATA = Path(__file__).parent / "data"
K = np.array([[500.0, 0.0, 32.0], [0.0, 500.0, 24.0], [0.0, 0.0, 1.0]])


@pytest.fixture(scope="module")
def camera() -> Camera:
    return Camera.look_at((0.6, 0.0, 0.5), (0.0, 0.0, 0.0), K, 64, 48)


@pytest.fixture(scope="module")
def depth() -> np.ndarray:
    rng = np.random.default_rng(0)
    d = rng.uniform(0.5, 1.5, (48, 64)).astype(np.float32)
    d[:5, :7] = 0.0
    return d


# -- depth frames ---------------------------------------------------------------------------------


def test_png_json_round_trip(tmp_path, camera, depth):
    write_depth_png(tmp_path / "f.png", depth, depth_scale=0.001)
    write_camera_json(tmp_path / "f.json", camera, depth_scale=0.001)
    frame = load_depth_frame(tmp_path / "f.png")
    assert frame.depth.dtype == np.float32 and frame.depth.shape == (48, 64)
    # 16-bit millimetres: half a unit of rounding error at most.
    np.testing.assert_allclose(frame.depth, depth, atol=0.0005 + 1e-6)
    assert np.all(frame.depth[:5, :7] == 0)
    np.testing.assert_allclose(frame.camera.K, camera.K)
    np.testing.assert_allclose(frame.camera.T_world_cam, camera.T_world_cam, atol=1e-12)
    # The frame's points are the depth back-projected by the camera (a numpy reference).
    v, u = np.nonzero(frame.depth > 0)
    z = frame.depth[v, u]
    pc = np.stack([(u - 32.0) / 500.0 * z, (v - 24.0) / 500.0 * z, z], axis=1)
    T = np.asarray(camera.T_world_cam)
    np.testing.assert_allclose(frame.points(), pc @ T[:3, :3].T + T[:3, 3], atol=1e-5)


def test_npy_npz_rgb_and_fx_schema(tmp_path, depth):
    (tmp_path / "cam.json").write_text(
        json.dumps({"width": 64, "height": 48, "fx": 500, "fy": 500, "cx": 32, "cy": 24})
    )
    np.save(tmp_path / "d.npy", depth)
    np.savez(tmp_path / "d.npz", depth=depth.astype(np.float64))
    import cv2

    rgb = np.zeros((48, 64, 3), np.uint8)
    rgb[..., 0] = 200  # red
    cv2.imwrite(str(tmp_path / "c.png"), rgb[..., ::-1])
    a = load_depth_frame(tmp_path / "d.npy", tmp_path / "cam.json", rgb_path=tmp_path / "c.png")
    b = load_depth_frame(tmp_path / "d.npz", tmp_path / "cam.json")
    np.testing.assert_array_equal(a.depth, depth)
    np.testing.assert_array_equal(b.depth, depth)
    np.testing.assert_array_equal(a.camera.K, K)
    np.testing.assert_array_equal(a.camera.T_world_cam, np.eye(4))
    assert (
        a.rgb.shape == (48, 64, 3) and np.all(a.rgb[..., 0] == 200) and np.all(a.rgb[..., 2] == 0)
    )


def _expect(exc, path, *words):
    """The error names the file and each word of the problem."""
    msg = str(exc.value)
    assert Path(path).name in msg, msg
    for w in words:
        assert w in msg, msg


def test_bad_depth_files(tmp_path, camera, depth):
    write_camera_json(tmp_path / "noscale.json", camera)
    write_depth_png(tmp_path / "d.png", depth)
    with pytest.raises(FileFormatError) as e:  # wrong units: no scale for a 16-bit PNG
        load_depth_frame(tmp_path / "d.png", tmp_path / "noscale.json")
    _expect(e, "d.png", "depth scale")
    # Float depth in millimetres.
    np.save(tmp_path / "mm.npy", depth * 1000)
    with pytest.raises(FileFormatError) as e:
        read_depth_image(tmp_path / "mm.npy")
    _expect(e, "mm.npy", "millimetres")
    # Corrupt and truncated files.
    (tmp_path / "junk.png").write_bytes(b"\x89PNG\r\n\x1a\n" + b"garbage" * 10)
    with pytest.raises(FileFormatError) as e:
        read_depth_image(tmp_path / "junk.png", 0.001)
    _expect(e, "junk.png", "decode")
    raw = (tmp_path / "d.png").read_bytes()
    (tmp_path / "trunc.png").write_bytes(raw[: len(raw) // 2])
    with pytest.raises(FileFormatError):
        read_depth_image(tmp_path / "trunc.png", 0.001)
    raw = (tmp_path / "mm.npy").read_bytes()
    (tmp_path / "trunc.npy").write_bytes(raw[: len(raw) // 2])
    with pytest.raises(FileFormatError) as e:
        read_depth_image(tmp_path / "trunc.npy")
    _expect(e, "trunc.npy")
    # 8-bit PNG, unknown format, wrong size, missing file.
    import cv2

    cv2.imwrite(str(tmp_path / "eight.png"), np.zeros((48, 64), np.uint8))
    with pytest.raises(FileFormatError) as e:
        read_depth_image(tmp_path / "eight.png", 0.001)
    _expect(e, "eight.png", "16-bit")
    (tmp_path / "d.tiff").write_bytes(b"II*\x00")
    with pytest.raises(FileFormatError) as e:
        read_depth_image(tmp_path / "d.tiff")
    _expect(e, "d.tiff", "unknown depth format")
    np.save(tmp_path / "small.npy", depth[:10])
    with pytest.raises(FileFormatError) as e:
        load_depth_frame(tmp_path / "small.npy", camera)
    _expect(e, "small.npy", "(10, 64)")
    with pytest.raises(MissingFileError):
        read_depth_image(tmp_path / "absent.npy")
    with pytest.raises(MissingFileError):  # no camera given and none beside the depth
        load_depth_frame(tmp_path / "small.npy")


@pytest.mark.parametrize(
    "content, words",
    [
        ('{"width": 64, "height": 48}', ["missing key", "fx"]),
        ('{"height": 48, "K": [[1,0,0],[0,1,0],[0,0,1]]}', ["missing key", "width"]),
        ('{"width": 64, "height": 48, "K": [[1,0,0],[0,1,0]]}', ["K", "(3, 3)"]),
        ('{"width": 64, "height": 48, "K": [[-5,0,0],[0,5,0],[0,0,1]]}', ["invalid camera"]),
        (
            '{"width": 64, "height": 48, "fx": 5, "fy": 5, "cx": 1, "cy": 1, "depth_scale": -1}',
            ["depth_scale"],
        ),  # fmt: skip
        ('{"width": 64, "height": ', ["not valid JSON"]),
        ("[1, 2]", ["JSON object"]),
    ],
)
def test_bad_camera_json(tmp_path, content, words):
    p = tmp_path / "cam.json"
    p.write_text(content)
    with pytest.raises(FileFormatError) as e:
        load_camera_json(p)
    _expect(e, "cam.json", *words)


# -- point clouds ---------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def cloud():
    rng = np.random.default_rng(1)
    pts = rng.normal(0, 0.1, (500, 3))
    cols = rng.integers(0, 256, (500, 3)).astype(np.uint8)
    nrm = rng.normal(size=(500, 3))
    return pts, cols, nrm / np.linalg.norm(nrm, axis=1, keepdims=True)


@pytest.mark.parametrize("suffix", [".ply", ".pcd", ".npz"])
@pytest.mark.parametrize("binary", [True, False])
def test_cloud_round_trip(tmp_path, cloud, suffix, binary):
    pts, cols, nrm = cloud
    p = write_point_cloud(
        tmp_path / f"c{suffix}", pts, cols, nrm, binary=binary, viewpoint=(1, 2, 3)
    )
    back = read_point_cloud(p)
    tol = 1e-12 if suffix == ".npz" else 1e-6  # PLY and PCD store float32
    np.testing.assert_allclose(back.points, pts, atol=tol)
    np.testing.assert_array_equal(back.colors, cols)
    np.testing.assert_allclose(back.normals, nrm, atol=tol)
    if suffix != ".ply":
        np.testing.assert_allclose(back.viewpoint, [1, 2, 3])
    mm = read_point_cloud(p, scale=0.001)
    np.testing.assert_allclose(mm.points, back.points * 0.001)


def test_handwritten_pcd():
    c = read_point_cloud(DATA / "tiny_ascii.pcd")
    np.testing.assert_allclose(c.points, [[0.5, 0, 1.25], [0, 0.5, 1.5], [-0.25, 0.125, 2]])
    np.testing.assert_array_equal(c.colors, [[255, 0, 0], [0, 255, 0], [0, 0, 255]])
    np.testing.assert_allclose(c.viewpoint, [0.1, 0.2, 0.3])


def test_bad_cloud_files(tmp_path, cloud):
    pts, cols, _ = cloud
    good = write_point_cloud(tmp_path / "g.pcd", pts, cols).read_bytes()
    (tmp_path / "trunc.pcd").write_bytes(good[:-100])
    with pytest.raises(FileFormatError) as e:
        read_point_cloud(tmp_path / "trunc.pcd")
    _expect(e, "trunc.pcd", "truncated")
    (tmp_path / "comp.pcd").write_bytes(good.replace(b"DATA binary", b"DATA binary_compressed"))
    with pytest.raises(FileFormatError) as e:
        read_point_cloud(tmp_path / "comp.pcd")
    _expect(e, "comp.pcd", "binary_compressed")
    (tmp_path / "noz.pcd").write_bytes(good.replace(b"FIELDS x y z", b"FIELDS x y w"))
    with pytest.raises(FileFormatError) as e:
        read_point_cloud(tmp_path / "noz.pcd")
    _expect(e, "noz.pcd", "'z'")
    text = write_point_cloud(tmp_path / "a.pcd", pts, binary=False).read_text()
    (tmp_path / "short.pcd").write_text(text[: len(text) // 2])
    with pytest.raises(FileFormatError) as e:
        read_point_cloud(tmp_path / "short.pcd")
    _expect(e, "short.pcd")
    ply = write_point_cloud(tmp_path / "g.ply", pts).read_bytes()
    (tmp_path / "trunc.ply").write_bytes(ply[: len(ply) // 2])
    (tmp_path / "junk.ply").write_bytes(b"not a ply at all\n" * 5)
    for name in ("trunc.ply", "junk.ply"):
        with pytest.raises(FileFormatError) as e:
            read_point_cloud(tmp_path / name)
        _expect(e, name)
    np.savez(tmp_path / "nopoints.npz", xyz=pts)
    with pytest.raises(FileFormatError) as e:
        read_point_cloud(tmp_path / "nopoints.npz")
    _expect(e, "nopoints.npz", "points")
    (tmp_path / "c.xyz").write_text("1 2 3\n")
    with pytest.raises(FileFormatError) as e:
        read_point_cloud(tmp_path / "c.xyz")
    _expect(e, "c.xyz", "unknown point-cloud format")
    with pytest.raises(SymjaxError):
        write_point_cloud(tmp_path / "bad.ply", pts[:, :2])


def test_cloud_observation_from_viewpoint(camera):
    # A flat patch facing the viewpoint: its virtual camera looks at the centroid.
    g = np.stack(np.meshgrid(np.linspace(-0.05, 0.05, 20), np.linspace(-0.05, 0.05, 20)), -1)
    pts = np.concatenate([g.reshape(-1, 2), np.full((400, 1), 0.05)], axis=1)
    obs = cloud_observation(pts, TablePlane.horizontal(), viewpoint=(0.0, -0.4, 0.6))
    uv, z = obs.camera.project(pts.mean(axis=0))
    np.testing.assert_allclose(np.asarray(uv), [320.0, 240.0], atol=1e-6)
    assert obs.mask.sum() >= 400 and obs.n_valid == 400
    with pytest.raises(SymjaxError):
        cloud_observation(pts, TablePlane.horizontal())


# -- meshes ---------------------------------------------------------------------------------------


@pytest.mark.parametrize("suffix", [".ply", ".obj", ".stl"])
def test_mesh_round_trip(tmp_path, suffix):
    import trimesh

    box = trimesh.creation.box((0.1, 0.2, 0.3))
    p = write_mesh(tmp_path / f"m{suffix}", box)
    back = read_mesh(p)
    assert abs(back.volume - 0.006) < 1e-7  # PLY and STL store float32
    np.testing.assert_allclose(back.bounds, box.bounds, atol=1e-7)
    p2 = write_mesh(tmp_path / f"v{suffix}", box.vertices, box.faces)
    assert abs(read_mesh(p2).area - box.area) < 1e-6


def test_bad_mesh(tmp_path):
    with pytest.raises(FileFormatError) as e:
        write_mesh(tmp_path / "m.dae", np.zeros((3, 3)), [[0, 1, 2]])
    _expect(e, "m.dae", "unknown mesh format")
    with pytest.raises(SymjaxError):
        write_mesh(tmp_path / "m.ply", np.zeros((3, 3)), [[0, 1, 5]])
    (tmp_path / "bad.stl").write_bytes(b"solid x\nfacet normal 0 0 1\n outer loop\n vertex 1 2")
    with pytest.raises(FileFormatError) as e:
        read_mesh(tmp_path / "bad.stl")
    _expect(e, "bad.stl")


# -- the KTH per-view format ----------------------------------------------------------------------


def _write_synthetic_kth(folder: Path, deg: int, rng) -> np.ndarray:
    """A KTH view made by back-projecting pixels of a camera at a known viewpoint (mm)."""
    Kl = np.array([[2200.0, 0, 330.0], [0, 2210.0, 230.0], [0, 0, 1]])
    vp = np.array([600.0, 900.0, 500.0]) * (1 + deg / 1000)
    cam = Camera.look_at(vp / 1000, (0.01, 0.02, 0.0), Kl, 640, 480)
    u, v = np.meshgrid(np.arange(300, 340), np.arange(200, 230))
    u, v = u.ravel(), v.ravel()
    z = rng.uniform(1.1, 1.2, u.size)
    xc = np.stack([(u - 330.0) / 2200.0 * z, (v - 230.0) / 2210.0 * z, z], axis=1)
    T = np.asarray(cam.T_world_cam)
    xyz = (xc @ T[:3, :3].T + T[:3, 3]) * 1000
    rows = np.column_stack([xyz, u, v, rng.integers(0, 256, (u.size, 3))])
    folder.mkdir(parents=True, exist_ok=True)
    body = "\n".join(
        " ".join(f"{x:.6f}" if i < 3 else f"{int(x)}" for i, x in enumerate(r)) for r in rows
    )
    (folder / f"segment_{deg:03d}.crd").write_text(f"{len(rows)}\n{body}")
    (folder / f"viewPoint_{deg:03d}.txt").write_text(" ".join(f"{x:.6f}" for x in vp))
    return xyz


def _write_calib(folder: Path):
    nums = [2200, 0, 330, 0, 2210, 230, 0, 0, 1, 0, 0, 0, 0] * 2 + [90, 0, 0, 1, 0, 0, 0]
    nums += [0] * 9 + [640, 480] + [0] * 18
    (folder / "calib.txt").write_text(" ".join(str(x) for x in nums))


def test_kth_directory_layout(tmp_path):
    rng = np.random.default_rng(2)
    _write_calib(tmp_path)
    truth = {}
    for obj in ("mug", "box/small"):
        for deg in (0, 45, 315):
            truth[(obj, deg)] = _write_synthetic_kth(tmp_path / obj, deg, rng)
    views = load_kth_directory(tmp_path)
    assert [(v.name, v.degree) for v in views] == sorted(truth)
    for v in views:
        np.testing.assert_allclose(
            v.observation.valid_points(), truth[(v.name, v.degree)] / 1000, atol=1e-6
        )
        c = v.uv_consistency()
        assert c["iou"] == 1.0 and c["max_px"] < 1e-3 and c["depth_max_err"] < 1e-5, c
        assert v.fit_rms_px < 1e-3
    with pytest.raises(MissingFileError):
        load_kth_directory(tmp_path / "nothing")


def test_kth_bad_files(tmp_path):
    rng = np.random.default_rng(3)
    _write_calib(tmp_path)
    _write_synthetic_kth(tmp_path, 90, rng)
    crd = tmp_path / "segment_090.crd"
    text = crd.read_text()
    (tmp_path / "segment_091.crd").write_text(text[: len(text) * 2 // 3])
    shutil.copy(tmp_path / "viewPoint_090.txt", tmp_path / "viewPoint_091.txt")
    with pytest.raises(FileFormatError) as e:
        load_kth_view(tmp_path / "segment_091.crd")
    _expect(e, "segment_091.crd", "truncated")
    (tmp_path / "segment_092.crd").write_text(text.replace("\n", "\nabc ", 1))
    with pytest.raises(FileFormatError) as e:
        read_kth_segment(tmp_path / "segment_092.crd")
    _expect(e, "segment_092.crd", "numbers")
    shutil.copy(crd, tmp_path / "segment_093.crd")
    with pytest.raises(MissingFileError) as e:
        load_kth_view(tmp_path / "segment_093.crd")
    _expect(e, "viewPoint_093.txt")
    (tmp_path / "viewPoint_093.txt").write_text("1 2")
    with pytest.raises(FileFormatError) as e:
        load_kth_view(tmp_path / "segment_093.crd")
    _expect(e, "viewPoint_093.txt", "3 finite numbers")
    (tmp_path / "calib.txt").write_text("1 2 3")
    with pytest.raises(FileFormatError) as e:
        load_kth_view(crd)
    _expect(e, "calib.txt", "44")


def test_kth_real_view(shared_dir):
    from symjax.symmetry import search

    view = load_kth_view(shared_dir / "kth_demo" / "segment_000.crd")
    obs = view.observation
    assert obs.n_valid == 40576 and view.degree == 0
    # Consistent with the file's u v columns: every point projects to its own (u, v) pixel,
    # the projected pixel set is exactly the u v pixel set, the mask covers it and the depth image
    # holds each point's camera depth there.
    c = view.uv_consistency()
    assert c["iou"] == 1.0 and c["mask_recall"] == 1.0, c
    assert c["max_px"] < 0.01 and c["depth_max_err"] < 1e-5, c
    np.testing.assert_allclose(
        obs.camera.position, np.loadtxt(shared_dir / "kth_demo" / "viewPoint_000.txt") / 1000
    )
    pts = obs.valid_points()
    assert 0.5 < np.linalg.norm(pts.mean(axis=0) - np.asarray(obs.camera.position)) < 1.5  # metres
    np.testing.assert_allclose(obs.table.normal, [0, 0, 1])
    assert np.percentile(np.asarray(obs.table.height(pts)), 1) > -0.002
    # The reference code's virtual camera: same centre, aimed at the centroid, ~53 px off.
    look = load_kth_view(shared_dir / "kth_demo" / "segment_000.crd", camera="look_at")
    uv, _ = look.observation.camera.project(pts.mean(axis=0))
    np.testing.assert_allclose(
        np.asarray(uv), np.asarray(look.observation.camera.K)[:2, 2], atol=0.01
    )
    assert 20 < look.fit_rms_px < 100
    res = search(obs)
    n = np.asarray(res.normal)
    assert np.all(np.isfinite(n)) and abs(n[2]) < 1e-3  # a plane perpendicular to the table
    done = res.completed_cloud()
    assert done.shape[1] == 3 and len(done) > obs.n_valid


def test_kth_real_view_in_database_layout(shared_dir, tmp_path):
    demo = shared_dir / "kth_demo"
    shutil.copy(demo / "calib.txt", tmp_path / "calib.txt")
    for obj, deg in (("cup", "000"), ("cup", "045"), ("can", "000")):
        (tmp_path / obj).mkdir(exist_ok=True)
        shutil.copy(demo / "segment_000.crd", tmp_path / obj / f"segment_{deg}.crd")
        shutil.copy(demo / "viewPoint_000.txt", tmp_path / obj / f"viewPoint_{deg}.txt")
    views = load_kth_directory(tmp_path)
    assert [(v.name, v.degree) for v in views] == [("can", 0), ("cup", 0), ("cup", 45)]
    assert all(v.observation.n_valid == 40576 and v.fit_rms_px < 1e-3 for v in views)
