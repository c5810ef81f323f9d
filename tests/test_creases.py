"""Touching objects apart: the concave-crease cut, parts joined to their support, occluders kept
for the symmetry search, the table frame without a camera pose, on stereo-noise clutter."""

from __future__ import annotations

import math

import numpy as np
import pytest

from symjax import configs
from symjax.camera import Camera
from symjax.errors import DegenerateGeometryError, InvalidInputError
from symjax.geometry import pixel_rays
from symjax.perception import SegmentationConfig, segment
from symjax.perception.clutter_benchmark import match_ious
from symjax.perception.creases import concavity
from symjax.perception.synthetic import clutter_scene

F = 575.0
#: The ``clutter`` preset's segmentation: the crease cut on.
CLUTTER = configs.load("clutter").segmentation


def _match_ious(truth: np.ndarray, scene) -> np.ndarray:
    """Best one-to-one IoU of each truth object with a found object (0 when unmatched)."""
    return match_ious(truth, scene)[0]


def _plane_depth(n_cam, d, H=120, W=160):
    """Depth (H, W) of the plane {x : n . x = d} in a camera at the origin (camera frame)."""
    K = np.array([[F, 0, W / 2], [0, F, H / 2], [0, 0, 1.0]])
    rays = pixel_rays(K, H, W)
    return (d / (rays @ np.asarray(n_cam, float))).astype(np.float32)


def test_concavity_is_zero_on_planes_and_signs_valleys_and_ridges():
    # Flat faces at any slant: inverse depth is affine in the pixels, so no bend at all.
    for n in ([0, 0, -1], [0.5, 0.2, -0.8], [-0.3, 0.6, -0.7]):
        n = np.asarray(n) / np.linalg.norm(n)
        k = concavity(_plane_depth(n, -1.0), F, scale_px=4, smooth_px=0)
        assert np.abs(k[8:-8, 8:-8]).max() < 1e-3
    # A 90 deg wedge z = 1 - c |x| along a vertical line: c = 1 is a valley (its middle is
    # the farthest, tan(45 deg) = 1 at the line), c = -1 the ridge that mirrors it (no
    # direction bends concavely there: the largest bend is that of the flat vertical one, 0).
    H, W = 120, 160
    K = np.array([[F, 0, W / 2], [0, F, H / 2], [0, 0, 1.0]])
    xr = pixel_rays(K, H, W)[..., 0]
    for c in (1.0, -1.0):
        depth = (1.0 / (1.0 + c * np.abs(xr))).astype(np.float32)  # z = 1 - c |x z|
        k = concavity(depth, F, scale_px=4, smooth_px=0)
        at = k[H // 2, W // 2 - 1 : W // 2 + 2]
        assert (at.max() > 0.5) if c > 0 else (at.max() < 1e-3), (c, at)
        assert np.abs(k[:, :40]).max() < 1e-3  # flat away from the line


@pytest.fixture(scope="module")
def pair_scenes():
    kinds = (("box", "can"), ("can", "can"), ("bottle", "box"))
    out = [(k, s, "side_by_side") for k in kinds for s in range(4)]
    out += [(k, s, "front_back") for k in (("box", "can"), ("can", "box")) for s in range(4)]
    return [clutter_scene(k, seed=s, arrangement=a) for k, s, a in out]


def _concavity_reference(z, focal, scale_px, max_step):
    """Eq. of :func:`concavity` without smoothing, a direction and a pixel at a time."""
    H, W = z.shape
    w = np.where(z > 0, 1.0 / np.maximum(z, 1e-6), 0.0)
    out = np.zeros((H, W))
    for r in range(H):
        for c in range(W):
            if w[r, c] <= 0:
                continue
            best = -np.inf
            for dr, dc in ((0, 1), (1, 0), (1, 1), (1, -1)):
                span = scale_px * math.hypot(dr, dc)
                ends = [(r - dr * scale_px, c - dc * scale_px)]
                ends.append((r + dr * scale_px, c + dc * scale_px))
                ok = all(0 <= y < H and 0 <= x < W and w[y, x] > 0 for y, x in ends)
                ok = ok and all(abs(z[y, x] - z[r, c]) < max_step for y, x in ends)
                d2 = sum(w[y, x] for y, x in ends) - 2.0 * w[r, c] if ok else 0.0
                best = max(best, d2 * z[r, c] * focal / (2.0 * span))
            out[r, c] = best
    return out


@pytest.mark.parametrize("max_step", [np.inf, 0.02])
def test_concavity_matches_the_pixel_by_pixel_reference(max_step):
    rng = np.random.default_rng(3)
    cols = np.abs(np.arange(27) - 13.0)
    z = (0.65 + 0.0015 * cols + rng.uniform(0.0, 0.002, (19, 27))).astype(np.float32)
    z[rng.random(z.shape) < 0.15] = 0.0  # no depth
    z[5:9] += 0.05  # a step, larger than max_step
    got = concavity(z, F, scale_px=3, smooth_px=0, max_step=max_step)
    want = _concavity_reference(z.astype(np.float64), F, 3, max_step)
    assert got.dtype == np.float32
    # float32 second differences of inverse depth (~1.5 /m) against float64 ones, times
    # z f / (2 span) ~ 60: a few 1e-5 apart at most.
    np.testing.assert_allclose(got, want, rtol=1e-4, atol=5e-5)
    assert (want > 1e-3).any() and (want < -1e-3).any()


def test_touching_pairs_come_apart(pair_scenes):
    right = 0
    for sc in pair_scenes:
        assert sc.contacts == ((0, 1),)  # the generator really made them touch
        res = segment(sc.depth, sc.camera, CLUTTER)
        ious = _match_ious(sc.truth, res)
        right += len(res) == 2 and ious.min() >= 0.85
    # Measured 19 of 20 (one pair of cans stays joined through their coplanar lids).
    assert right >= 0.9 * len(pair_scenes), right
    # Without the crease cut the same scenes come out merged: the cut is what separates them.
    merged = sum(
        len(segment(sc.depth, sc.camera, SegmentationConfig(crease_threshold=None))) == 2
        for sc in pair_scenes[:12]
    )
    assert merged <= 2


def test_occluders_keep_their_depth_for_the_symmetry_search(pair_scenes):
    from symjax.symmetry.view import mask_distance

    sc = pair_scenes[12]  # box in front of a can that it partly hides
    res = segment(sc.depth, sc.camera, CLUTTER)
    back = int(np.argmax([(sc.truth == 1)[np.asarray(o.mask)].mean() for o in res.objects]))
    front = 1 - back
    assert res.info[back].occluded_by == (front,)
    obs = res.objects[back]
    mask, depth = np.asarray(obs.mask), np.asarray(obs.depth)
    occ = ~mask & (depth > 0)
    front_px = np.asarray(res.objects[front].mask) & (sc.depth > 0)
    assert occ.sum() > 0.5 * front_px.sum()
    np.testing.assert_allclose(depth[occ], sc.depth[occ])
    # Behind the occluder is not "seen empty": no distance to the mask there.
    assert np.all(mask_distance(mask, depth)[occ] == 0)
    # The front object has nothing in front of it: its depth stays on its mask.
    f = res.objects[front]
    assert not np.any(~np.asarray(f.mask) & (np.asarray(f.depth) > 0))


def test_clutter_is_split_into_its_objects():
    sc = clutter_scene(("box", "can", "bottle", "can", "box", "can"), seed=1)
    assert len(sc.contacts) >= 3
    res = segment(sc.depth, sc.camera, CLUTTER)
    assert len(res) == 6
    assert _match_ious(sc.truth, res).min() >= 0.85


@pytest.mark.parametrize(
    "kinds, seed",
    [
        # The near bottle hides the far one's middle: its neck and shoulder float above the
        # table and meet only a strip of its body, from above (the creases cut the shoulder off).
        (("bottle", "can", "box", "can", "bottle", "box"), 53),
        # A mostly hidden bottle's neck and shoulder meet the box beside them level: they stay
        # with the bottle, not the box.
        (("bottle", "bottle", "box", "can", "box", "can"), 143),
    ],
)
def test_hidden_bottle_keeps_its_neck_and_shoulder(kinds, seed):
    sc = clutter_scene(kinds, seed=seed)
    res = segment(sc.depth, sc.camera, CLUTTER)
    assert len(res) == len(kinds)
    assert _match_ious(sc.truth, res).min() >= 0.85


def test_table_frame_without_camera_pose():
    sc = clutter_scene(("box", "can", "bottle"), seed=1, arrangement="side_by_side")
    posed = segment(sc.depth, sc.camera, CLUTTER)
    cam = Camera.create(sc.camera.K, np.eye(4), sc.camera.width, sc.camera.height)
    res = segment(sc.depth, cam, CLUTTER)
    assert posed.frame == "given" and res.frame == "table"
    np.testing.assert_allclose(np.asarray(res.table.normal), [0, 0, 1], atol=1e-6)
    assert abs(float(res.table.offset)) < 1e-6
    np.testing.assert_array_equal(res.labels, posed.labels)
    # The table frame is the true one up to a rotation about z and a shift on the table:
    # heights above the table agree with the posed frame's.
    for a, b in zip(posed.objects, res.objects, strict=True):
        za = np.sort(a.valid_points() @ np.asarray(posed.table.normal) + float(posed.table.offset))
        np.testing.assert_allclose(np.sort(b.valid_points()[:, 2]), za, atol=2e-4)
    c = np.mean([i.centroid for i in res.info], axis=0)
    assert np.linalg.norm(c[:2]) < 1e-6  # origin below the objects' centre
    # T_world_input maps the camera-frame points onto the reported ones.
    T = res.T_world_input
    np.testing.assert_allclose(T[:3, :3] @ T[:3, :3].T, np.eye(3), atol=1e-9)
    cam_pts = sc.camera.world_to_camera(posed.objects[0].valid_points())
    np.testing.assert_allclose(
        np.asarray(cam_pts) @ T[:3, :3].T + T[:3, 3], res.objects[0].valid_points(), atol=1e-4
    )
    # The camera looks along +x of the table frame.
    assert np.asarray(res.objects[0].camera.T_world_cam)[0, 2] > 0.5


def test_frame_without_a_dominant_plane_is_refused():
    rng = np.random.default_rng(0)
    depth = rng.uniform(0.5, 2.0, (240, 320)).astype(np.float32)
    K = np.array([[300.0, 0, 160], [0, 300, 120], [0, 0, 1]])
    with pytest.raises(DegenerateGeometryError, match="no table"):
        segment(depth, Camera.create(K, np.eye(4), 320, 240))


def test_real_kth_view_on_its_table_is_one_object(shared_dir):
    from symjax.io.kth import load_kth_view

    obs = load_kth_view(shared_dir / "kth_demo" / "segment_000.crd").observation
    cam = obs.camera
    T = np.asarray(cam.T_world_cam, np.float64)
    rays = pixel_rays(np.asarray(cam.K, np.float64), cam.height, cam.width) @ T[:3, :3].T
    n, d = np.asarray(obs.table.normal, np.float64), float(obs.table.offset)
    t = -(T[:3, 3] @ n + d) / (rays @ n)
    depth = np.asarray(obs.depth, np.float64)
    # The segment file holds the object alone: the table it stood on is put back as a plane.
    frame = np.where(depth > 0, depth, np.where(t > 0, t, 0)).astype(np.float32)
    for cfg in (SegmentationConfig(), CLUTTER):  # real stereo noise does not cut it up
        assert len(segment(frame, cam, cfg)) == 1
    res = segment(frame, cam, CLUTTER)
    m = np.asarray(obs.mask)
    iou = (np.asarray(res.objects[0].mask) & m).sum() / (np.asarray(res.objects[0].mask) | m).sum()
    assert iou > 0.85


@pytest.mark.parametrize(
    "kw, match",
    [
        ({"kinds": ("box", "teapot")}, "teapot"),
        ({"kinds": ("box", "can"), "arrangement": "pile"}, "pile"),
    ],
)
def test_clutter_scene_bad_input(kw, match):
    with pytest.raises(InvalidInputError, match=match):
        clutter_scene(**kw)


def test_clutter_camera_sees_all_objects():
    sc = clutter_scene(("box", "can", "bottle", "box", "can"), seed=2, width=1280, height=720)
    assert sc.depth.shape == (720, 1280)
    assert all((sc.truth == i).any() for i in range(5))
    assert math.isclose(float(sc.camera.K[0, 0]), 1150.0)


@pytest.mark.parametrize("robot, seed", [("kth", 0), ("kth", 4), ("uji", 2)])
def test_hollow_objects_stay_whole(robot, seed, tmp_path_factory):
    from symjax.datasets.scan_scenes import scan_scene

    # Mugs, cups and a bowl seen from the robots' heads: their insides are concave behind the
    # rim and their handles meet the body in a crease, yet each must stay one object.
    sc = scan_scene(robot, 2 + seed % 4, seed=seed, cache_dir=tmp_path_factory.mktemp("scans"))
    truth = np.where(sc.labels >= 1, sc.labels - 1, -1)
    plain = _match_ious(truth, segment(sc.depth, sc.camera))
    res = segment(sc.depth, sc.camera, CLUTTER)
    assert len(res) == len(sc.names), sc.names
    np.testing.assert_array_less(plain - 0.1, _match_ious(truth, res))


def test_colour_image_is_a_further_cue():
    # Clutter scene 196 of the 270 examined: boxes 1 and 2 stand face to face, one surface from
    # depth alone (4 objects found); their colours tell them apart. The cans' and the bottle's
    # label bands (colour edges on convex faces) cut nothing. (Until 2026-12-06 this was scene
    # 213, a bottle behind a bottle, which the round objects' split now separates from depth
    # (a gap of up to 30 deg in the wall); before that scene 9, two bottles' shoulders behind
    # two boxes, which the occluded-halves join now mends.)
    kinds = ("can", "box", "box", "bottle", "can")
    sc = clutter_scene(kinds, seed=416)
    assert sc.rgb.shape == sc.depth.shape + (3,) and sc.rgb.dtype == np.uint8
    alone = segment(sc.depth, sc.camera, CLUTTER)
    assert len(alone) == 4 and np.sort(_match_ious(sc.truth, alone))[0] < 0.85
    res = segment(sc.depth, sc.camera, CLUTTER, rgb=sc.rgb)
    assert len(res) == 5
    assert np.min(_match_ious(sc.truth, res)) >= 0.85
    # A DepthFrame's own colour image is used.
    from symjax.io import DepthFrame

    frame = DepthFrame(depth=sc.depth, camera=sc.camera, rgb=sc.rgb)
    np.testing.assert_array_equal(segment(frame, config=CLUTTER).labels, res.labels)
