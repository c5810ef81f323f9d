"""Symmetry-plane search: kernel vs numpy reference, invariances, accuracy on synthetic views."""

from __future__ import annotations

import dataclasses
import math

import _scenes
import jax
import jax.numpy as jnp
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from symjax import Camera, Observation, TablePlane
from symjax.errors import CameraError, ConfigError, EmptyInputError, ShapeError, SymjaxError
from symjax.symmetry import (
    SymmetryConfig,
    complete,
    prepare_view,
    reflect,
    score_planes,
    search,
    search_batch,
)
from symjax.symmetry.reference import score_planes_numpy

KINDS = ("box", "cylinder", "bottle")
ORIENTATIONS = [math.radians(45 * k) for k in range(8)]


@pytest.fixture(scope="module")
def views():
    """24 noisy views: 3 symmetric objects x 8 orientations (0, 45, ..., 315 deg)."""
    out = []
    for kind in KINDS:
        for k, yaw in enumerate(ORIENTATIONS):
            obs, planes = _scenes.view(kind, yaw, noise=0.001, seed=k)
            out.append((kind, k, obs, planes))
    return out


@pytest.fixture(scope="module")
def batch_result(views):
    return search_batch([v[2] for v in views], SymmetryConfig())


def test_batch_finds_true_planes_within_5deg_5mm(views, batch_result):
    good = []
    for i, (_kind, _k, _, planes) in enumerate(views):
        r = batch_result[i]
        ang, off = _scenes.plane_error(r.normal, r.offset, planes)
        good.append(ang <= 5.0 and off <= 0.005)
    for kind in KINDS:
        rate = np.mean([g for g, v in zip(good, views, strict=True) if v[0] == kind])
        assert rate >= 0.9, f"{kind}: {rate:.0%} of views within 5 deg / 5 mm"


def test_single_search_matches_batch(views, batch_result, strict_ranks):
    kind, k, obs, _ = views[3]
    r = search(obs)
    b = batch_result[3]
    np.testing.assert_allclose(np.asarray(r.normal), np.asarray(b.normal), atol=1e-5)
    np.testing.assert_allclose(float(r.offset), float(b.offset), atol=1e-5)
    np.testing.assert_allclose(np.asarray(r.votes), np.asarray(b.votes), rtol=2e-3, atol=1e-5)


def test_vmapped_chunks_agree_and_keep_views_apart(views, batch_result):
    """The GPU path (views vmapped two at a time): the one-by-one planes to float32 rounding,
    and a view's result does not depend on the views beside it, bit for bit."""
    from symjax.execution import ExecutionConfig

    ex = ExecutionConfig(symmetry_chunk_views=2)
    three = search_batch([v[2] for v in views[:3]], None, ex)
    alone = search_batch([views[0][2]], None, ex)
    for i in range(3):
        np.testing.assert_allclose(three[i].normal, batch_result[i].normal, atol=1e-5)
    assert np.array_equal(three[0].votes, alone[0].votes)


def test_padding_costs_nothing_and_changes_nothing(views, batch_result):
    """A cloud padded far beyond its points (4x its bucket): the kernel's loop stops at the
    last valid point, and the plane and votes are those of the unpadded view."""
    from symjax.geometry import cloud_bucket

    obs = views[5][2]
    padded = obs.padded(4 * cloud_bucket(len(np.asarray(obs.points))))
    r, b = search(padded), batch_result[5]
    np.testing.assert_allclose(np.asarray(r.normal), np.asarray(b.normal), atol=1e-5)
    np.testing.assert_allclose(np.asarray(r.votes), np.asarray(b.votes), rtol=2e-3, atol=1e-5)


def test_view_arrays_pass_to_the_kernel_without_a_copy(views):
    """The big arrays of a packed view start on a 64-byte boundary, where XLA:CPU takes numpy
    arrays as they are (a copied 1280 x 960 image was a tenth of the paper's search); the
    values are those of a plain conversion."""
    from symjax.symmetry.view import ALIGNMENT, aligned_stack

    obs = views[3][2]
    view = prepare_view(obs, len(obs.points) + 100)
    for name in ("points", "valid", "image"):
        assert getattr(view, name).ctypes.data % ALIGNMENT == 0, name
    np.testing.assert_array_equal(view.points[: len(obs.points)], np.float32(obs.points))
    assert not view.valid[len(obs.points) :].any()
    stacked = aligned_stack([view.image, view.image[::-1]])
    assert stacked.ctypes.data % ALIGNMENT == 0
    np.testing.assert_array_equal(stacked[1], view.image[::-1])


@pytest.mark.parametrize(
    "normalize,huber", [("subset", 0.0), ("all", 0.0), ("subset", 1.0), ("subset", 2.5)]
)
def test_vmapped_scorer_equals_numpy_loop(views, normalize, huber, strict_ranks):
    obs = views[10][2]
    cfg = SymmetryConfig(normalize=normalize, outside_huber_px=huber)
    rng = np.random.default_rng(0)
    ang = rng.uniform(-np.pi, np.pi, 35)
    normals = np.stack([np.cos(ang), np.sin(ang), np.zeros_like(ang)], axis=1)
    offsets = rng.uniform(-0.03, 0.03, 35)
    ref_out, ref_in = score_planes_numpy(obs, normals, offsets, cfg)
    # The kernel is dtype-generic; run it in float64 so that the comparison checks the formula,
    # not float32 rounding of points lying on a pixel edge.
    with jax.enable_x64(True):
        view = _scenes.float64_view(obs)
        out, inside, votes = score_planes(
            view, jnp.asarray(normals, jnp.float64), jnp.asarray(offsets, jnp.float64), cfg
        )
        out, inside, votes = np.asarray(out), np.asarray(inside), np.asarray(votes)
    assert out.dtype == np.float64
    np.testing.assert_allclose(out, ref_out, rtol=1e-5, atol=1e-9)
    np.testing.assert_allclose(inside, ref_in, rtol=1e-5, atol=1e-9)
    np.testing.assert_allclose(
        votes, cfg.w_outside * ref_out + cfg.w_inside * ref_in, rtol=1e-5, atol=1e-9
    )
    # The float32 production path differs only by the rare pixel flip of a point on an edge.
    out32, in32, _ = score_planes(
        prepare_view(obs), jnp.asarray(normals, jnp.float32), jnp.asarray(offsets, jnp.float32), cfg
    )
    np.testing.assert_allclose(np.asarray(out32), ref_out, rtol=1e-3, atol=1e-3)
    np.testing.assert_allclose(np.asarray(in32), ref_in, rtol=1e-3, atol=1e-6)


def test_vote_grid_matches_numpy_on_paper_grid(views):
    obs = views[0][2]
    cfg = SymmetryConfig(init="eigen", n_refine=0)
    r = search(obs, cfg)
    n = np.array([0.0, 0.0, 1.0])
    m0 = np.cross(n, np.asarray(r.initial_axis))
    side = np.cross(n, m0)
    angles = np.asarray(r.angles)[0]
    normals = np.cos(angles)[:, None] * m0 + np.sin(angles)[:, None] * side
    offs = normals @ np.asarray(r.centroid, np.float64)
    N = np.repeat(normals, cfg.n_shifts, axis=0)
    O = (offs[:, None] + np.asarray(r.shifts)[None, :]).reshape(-1)
    ref_out, ref_in = score_planes_numpy(obs, N, O, cfg)
    np.testing.assert_allclose(
        np.asarray(r.vote_outside).reshape(-1), ref_out, rtol=1e-4, atol=1e-2
    )
    np.testing.assert_allclose(np.asarray(r.vote_inside).reshape(-1), ref_in, rtol=1e-4, atol=1e-6)
    assert r.votes.shape == (1, 7, 5) and cfg.n_hypotheses == 35


@settings(max_examples=25, deadline=None)
@given(
    n=st.integers(1, 64),
    ang=st.floats(-math.pi, math.pi),
    off=st.floats(-1.0, 1.0),
)
def test_mirroring_twice_is_identity(n, ang, off):
    rng = np.random.default_rng(n)
    p = rng.normal(size=(n, 3)).astype(np.float32)
    normal = jnp.asarray([math.cos(ang), math.sin(ang), 0.0], jnp.float32)
    with jax_ranks_raise():
        q = reflect(reflect(jnp.asarray(p), normal, off), normal, off)
    np.testing.assert_allclose(np.asarray(q), p, atol=1e-5)
    # Heights above the table are unchanged by a plane perpendicular to it.
    np.testing.assert_allclose(np.asarray(reflect(jnp.asarray(p), normal, off))[:, 2], p[:, 2])


@settings(max_examples=20, deadline=None)
@given(m=st.integers(2, 5000), rows=st.integers(1, 3), seed=st.integers(0, 2**16))
def test_percentiles_by_integer_sort_equal_jnp_percentile(m, rows, seed):
    from symjax.symmetry.hypotheses import _percentiles

    x = np.random.default_rng(seed).normal(size=(rows, m)).astype(np.float32)
    lo, hi = _percentiles(jnp.asarray(x), 2.0, 98.0)
    ref = np.asarray(jnp.percentile(jnp.asarray(x), jnp.array([2.0, 98.0]), axis=-1))
    scale = np.abs(x).max()
    np.testing.assert_allclose(np.asarray(lo), ref[0], rtol=0, atol=4e-6 * scale)
    np.testing.assert_allclose(np.asarray(hi), ref[1], rtol=0, atol=4e-6 * scale)


def jax_ranks_raise():
    import jax

    return jax.numpy_rank_promotion("raise")


def _rigid(yaw: float, t) -> np.ndarray:
    T = np.eye(4)
    c, s = math.cos(yaw), math.sin(yaw)
    # A rotation about a tilted axis as well, so the table is no longer z = 0.
    Rz = np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])
    a = 0.3
    Rx = np.array([[1, 0, 0], [0, math.cos(a), -math.sin(a)], [0, math.sin(a), math.cos(a)]])
    T[:3, :3] = Rx @ Rz
    T[:3, 3] = t
    return T


def test_result_moves_with_world_and_camera(views):
    obs = views[1][2]
    r0 = search(obs)
    T = _rigid(0.7, [0.3, -1.2, 0.5])
    r1 = search(obs.transformed(T))
    n_expected = T[:3, :3] @ np.asarray(r0.normal)
    np.testing.assert_allclose(np.asarray(r1.normal), n_expected, atol=2e-3)
    # The plane offset transforms as d' = d + n' . t.
    np.testing.assert_allclose(
        float(r1.offset), float(r0.offset) + n_expected @ T[:3, 3], atol=5e-4
    )
    moved = np.asarray(r0.mirrored) @ T[:3, :3].T + T[:3, 3]
    keep = np.asarray(r0.mirrored_keep)
    np.testing.assert_allclose(np.asarray(r1.mirrored)[keep], moved[keep], atol=2e-3)


def test_result_contents(views, batch_result):
    obs = views[8][2]  # cylinder at 0 deg
    r = batch_result[8]
    n = obs.n_valid
    cloud = r.completed_cloud()
    assert n < len(cloud) <= 2 * n
    plaus = np.asarray(r.plausibility)[np.asarray(r.valid)]
    assert np.all((plaus >= 0) & (plaus <= 1)) and plaus.mean() > 0.5
    # Kept mirrored points never lie in front of an observed surface.
    keep = np.asarray(r.mirrored_keep)
    uv, z = obs.camera.project(np.asarray(r.mirrored)[keep])
    col, row = np.rint(np.asarray(uv)).astype(int).T
    ok = (col >= 0) & (col < 640) & (row >= 0) & (row < 480)
    d = np.asarray(obs.depth)[row[ok], col[ok]]
    zz = np.asarray(z)[ok]
    assert np.all((d == 0) | (zz >= d - SymmetryConfig().depth_tolerance - 1e-6))
    # The completed cylinder's table-projected centroid is close to the axis (origin).
    assert np.linalg.norm(cloud[:, :2].mean(0)) < 0.01
    assert np.linalg.norm(obs.valid_points()[:, :2].mean(0)) > 0.015
    # Mirrored points are the reflection of the observed ones.
    np.testing.assert_allclose(
        np.asarray(r.mirrored),
        np.asarray(reflect(r.points, r.normal, r.offset)),
        atol=1e-6,
    )
    assert r.votes.shape == (2, 7, 5) and r.refine_votes.shape == (2, 7, 5)
    # The result never loses to the paper's own fan, and a bounding-box axis wins only by a margin.
    votes = np.asarray(r.votes)
    assert float(r.vote) <= float(votes[0].min()) + 1e-6
    assert float(r.vote) <= (1.0 + SymmetryConfig().start_margin) * float(votes.min()) + 1e-6


def test_box_favour_takes_a_nearly_square_box_faces_not_its_diagonal(monkeypatch):
    # A 6.4 x 6.6 cm box alone, seen across a corner: its diagonal votes better than its faces
    # (1.33 against 1.59), and the paper's axis is that diagonal, 45 deg off. With box_favour the
    # rectangle's face wins; a can and a bottle (round footprints) keep the default's plane.
    # (The benchmark counts this box's diagonals as mirror planes too: its half sides differ by
    # 1 mm. Here the faces alone are the truth.)
    from symjax import configs
    from symjax.perception import clutter_benchmark, segment
    from symjax.perception.clutter_benchmark import plane_error
    from symjax.perception.synthetic import clutter_scene

    monkeypatch.setattr(clutter_benchmark, "SQUARE_TOLERANCE", -1.0)

    kinds = ("box", "box", "can", "can", "bottle", "bottle", "bottle", "box")
    seg = configs.load("clutter").segmentation
    favour = SymmetryConfig(box_favour=0.7)
    for k in (0, 2, 4):
        sc = clutter_scene(kinds, seed=583, arrangement="cluster", only=k)
        (obs,) = segment(sc.depth, sc.camera, seg).objects
        default, boxed = search(obs), search(obs, favour)
        deg, dist = plane_error(sc, k, boxed.normal, boxed.offset)
        assert deg <= 10.0 and dist <= 0.010  # the benchmark's criterion
        if k == 0:
            assert plane_error(sc, k, default.normal, default.offset)[0] > 40.0
            assert int(default.best_start) == 0 and int(boxed.best_start) == 1
            assert float(boxed.vote) > float(default.vote)  # the prior, not the vote, decides
        else:
            np.testing.assert_array_equal(np.asarray(boxed.normal), np.asarray(default.normal))


@pytest.mark.parametrize(
    "kinds,seed,k,needs",
    [
        # Held-out clutter scene 38: neighbours hide half of box 1, and Eq. 1's rule keeps the
        # face whose mirror image falls on them; its fan drifts to a plane 28 deg off. Only the
        # other face finds it.
        (("can", "box", "can", "can", "box"), 634, 1, {"box_axes": 1}),
        # Held-out clutter scene 20: box 0's chain around the right face drifts 12 deg with the
        # full +-20 deg fan; +-2 deg keeps it on the face.
        (("box", "can", "can", "bottle", "box", "box", "can"), 606, 0, {"box_fan": 1.0}),
    ],
)
def test_clutter_preset_keeps_a_hidden_box_on_its_faces(kinds, seed, k, needs):
    from symjax import configs
    from symjax.perception import segment
    from symjax.perception.clutter_benchmark import match_ious, plane_error
    from symjax.perception.synthetic import clutter_scene

    def right(result):
        deg, dist = plane_error(sc, k, result.normal, result.offset)
        return deg <= 10.0 and dist <= 0.010  # the benchmark's criterion

    preset = configs.load("clutter")
    sc = clutter_scene(kinds, seed=seed, arrangement="cluster")
    res = segment(sc.depth, sc.camera, preset.segmentation)
    ious, match = match_ious(sc.truth, res)
    box = res.objects[match[k]]
    new = search(box, preset.symmetry)
    assert right(new) and new.votes.shape == (3, 7, 5)
    assert not right(search(box, SymmetryConfig(box_favour=0.7)))  # the preset before
    # Without the setting, under Eq. 3's square as when it was chosen (held-out 38's box 1 is
    # right with one axis too once the outside term grows linearly, outside_huber_px).
    square = dataclasses.replace(preset.symmetry, outside_huber_px=0.0)
    assert not right(search(box, dataclasses.replace(square, **needs)))
    if k == 1:
        # The can beside it (a round footprint) keeps the plane it had: no other axis, full fan.
        can = res.objects[match[0]]
        np.testing.assert_array_equal(
            np.asarray(search(can, preset.symmetry).normal),
            np.asarray(
                search(can, dataclasses.replace(preset.symmetry, box_axes=1, box_fan=1.0)).normal
            ),
        )


@pytest.mark.parametrize(
    "field,value",
    [
        ("box_favour", 1.0),
        ("box_favour", -0.1),
        ("box_rectangularity", 0.9),
        ("box_fan", 1.5),
        ("box_fan", -0.1),
        ("box_axes", 3),
        ("other_axis_favour", 1.0),
        ("outside_huber_px", -1.0),
        ("outside_huber_px", math.inf),
    ],
)
def test_box_favour_settings_are_checked(field, value):
    with pytest.raises(ConfigError, match=field):
        SymmetryConfig(**{field: value})


def test_complete_returns_a_list_of_clouds(views):
    obs = views[16][2]
    (cloud,) = complete(obs)
    assert cloud.shape[1] == 3 and len(cloud) > obs.n_valid
    np.testing.assert_allclose(cloud, search(obs).completed_cloud(), atol=1e-5)
    clouds = complete([views[16][2], views[17][2]])
    assert isinstance(clouds, list) and len(clouds) == 2
    np.testing.assert_allclose(clouds[0], cloud, atol=1e-5)


def test_views_of_different_sizes_batch(views):
    small = views[0][2]
    K = np.asarray(small.camera.K).copy()
    cam = Camera.create(K, np.asarray(small.camera.T_world_cam), 600, 420)
    pts = small.valid_points()
    uv, _ = cam.project(pts)
    uv = np.asarray(uv)
    inside = (uv[:, 0] < 599) & (uv[:, 1] < 419)
    cropped = Observation.from_points(pts[inside], cam, small.table)
    res = search_batch([cropped, views[1][2]])
    single = search(cropped)
    np.testing.assert_allclose(np.asarray(res[0].normal), np.asarray(single.normal), atol=1e-4)


# -- bad input -------------------------------------------------------------------------------


def _cam():
    K = np.array([[500.0, 0, 320], [0, 500.0, 240], [0, 0, 1]])
    return Camera.look_at([0.8, 0, 0.5], [0, 0, 0.05], K, 640, 480)


def test_bad_inputs_raise_symjax_errors():
    cam, table = _cam(), TablePlane.horizontal()
    good = np.random.default_rng(0).uniform(-0.03, 0.03, (100, 3)) + [0, 0, 0.05]
    with pytest.raises(EmptyInputError, match="empty"):
        Observation.from_points(np.zeros((0, 3)), cam, table)
    with pytest.raises(EmptyInputError, match="no finite"):
        Observation.from_points(np.full((50, 3), np.nan), cam, table)
    with pytest.raises(EmptyInputError, match="at least 10"):
        Observation.from_points(good[:9], cam, table)
    with pytest.raises(ShapeError, match=r"\(N, 3\)"):
        Observation.from_points(good[:, :2], cam, table)
    with pytest.raises(CameraError, match="behind the camera"):
        Observation.from_points(good + [2.0, 0, 0], cam, table)
    obs = Observation.from_points(good, cam, table)
    with pytest.raises(ShapeError, match="mask"):
        Observation.create(good, cam, table, np.asarray(obs.mask)[:-1], obs.depth)
    with pytest.raises(ShapeError, match="depth"):
        Observation.create(good, cam, table, obs.mask, np.asarray(obs.depth)[:, :-1])
    bad_K = np.array([[-500.0, 0, 320], [0, 500.0, 240], [0, 0, 1]])
    with pytest.raises(CameraError, match="focal"):
        Camera.create(bad_K, np.eye(4), 640, 480)
    with pytest.raises(CameraError, match="last row"):
        Camera.create(np.array([[500.0, 0, 320], [0, 500.0, 240], [0, 1, 1]]), np.eye(4), 640, 480)
    with pytest.raises(CameraError, match="NaN"):
        Camera.create(np.full((3, 3), np.nan), np.eye(4), 640, 480)
    with pytest.raises(ConfigError):
        SymmetryConfig(n_angles=0)
    with pytest.raises(ConfigError):
        SymmetryConfig(normalize="mean")
    with pytest.raises(SymjaxError):
        search_batch([])
    with pytest.raises(SymjaxError):
        search("not an observation")  # type: ignore[arg-type]


def test_nan_rows_are_dropped_not_propagated():
    cam, table = _cam(), TablePlane.horizontal()
    pts = np.random.default_rng(1).uniform(-0.03, 0.03, (200, 3)) + [0, 0, 0.05]
    pts[::7] = np.nan
    obs = Observation.from_points(pts, cam, table)
    assert obs.n_valid == 200 - len(pts[::7])
    r = search(obs, dataclasses.replace(SymmetryConfig(), n_refine=0))
    assert np.all(np.isfinite(np.asarray(r.normal)))


def test_mirror_across_the_found_plane_is_the_search_own_completion(views, batch_result):
    """mirror_across reproduces the search's mirrored points, kept mask and plausibility for
    its own plane, and mirrors across another plane as reflect() does (kept points behind the
    visible surface only)."""
    from symjax.symmetry import mirror_across, reflect

    obs, r = views[3][2], batch_result[3]
    same = mirror_across(r, obs, np.asarray(r.normal), float(r.offset))
    for f in ("mirrored", "mirrored_keep", "plausibility"):
        np.testing.assert_allclose(np.asarray(getattr(same, f), float),
                                   np.asarray(getattr(r, f), float), atol=1e-6)  # fmt: skip
    n = np.asarray(r.normal, float)
    turned = np.array([n[0] * 0.8 - n[1] * 0.6, n[0] * 0.6 + n[1] * 0.8, 0.0])  # 37 deg
    other = mirror_across(r, obs, 2.0 * turned, float(r.offset))  # normalised inside
    np.testing.assert_allclose(np.linalg.norm(np.asarray(other.normal)), 1.0, atol=1e-6)
    want = np.asarray(reflect(np.asarray(r.points), turned, float(r.offset)))
    np.testing.assert_allclose(np.asarray(other.mirrored), want, atol=1e-5)
    keep = np.asarray(other.mirrored_keep, bool)
    assert keep.sum() < np.asarray(r.valid, bool).sum() and not keep[~np.asarray(r.valid)].any()
    np.testing.assert_array_equal(np.asarray(other.votes), np.asarray(r.votes))  # kept
