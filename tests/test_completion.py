"""Completion choice: plane support, confidence, revolution fit and revolving, the fallback."""

from __future__ import annotations

import dataclasses
import math

import _scenes
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from symjax import TablePlane
from symjax.completion import (
    CONFIDENCE_MODEL,
    CompletionConfig,
    SupportIndex,
    choose_completion,
    fit_revolution,
    footprint_hull,
    plane_confidence,
    plane_support,
    revolve,
    roc_auc,
)
from symjax.completion.revolution import profile_consistent
from symjax.errors import ConfigError, DegenerateGeometryError, ShapeError
from symjax.surface import OrientedPoints, oriented_completion, poisson_reconstruct
from symjax.symmetry import search_batch

UP = np.array([0.0, 0.0, 1.0])


def _cylinder(radius=0.04, height=0.1, arc=(-2.0, 2.0), n=3000, centre=(0.1, -0.05), seed=0):
    """Oriented points of a cylinder's visible arc (radians), normals pointing outwards."""
    rng = np.random.default_rng(seed)
    t = rng.uniform(*arc, n)
    z = rng.uniform(0.0, height, n)
    normals = np.stack([np.cos(t), np.sin(t), np.zeros(n)], axis=1)
    points = np.stack([centre[0] + radius * np.cos(t), centre[1] + radius * np.sin(t), z], 1)
    return OrientedPoints(points, normals, np.ones(n), np.zeros(n, bool))


def _box_corner(n=3000, seed=0):
    """Two faces of a box meeting at a corner (a flat-sided surface)."""
    rng = np.random.default_rng(seed)
    a, z = rng.uniform(0.0, 0.08, n), rng.uniform(0.0, 0.1, n)
    face = rng.random(n) < 0.5
    points = np.where(face[:, None], np.stack([a, 0 * a, z], 1), np.stack([0 * a, a, z], 1))
    normals = np.where(face[:, None], [0.0, -1.0, 0.0], [-1.0, 0.0, 0.0])
    return OrientedPoints(points, normals, np.ones(n), np.zeros(n, bool))


# ---------------------------------------------------------------------------------- support --


def test_support_equals_a_brute_force_nearest_neighbour_count():
    rng = np.random.default_rng(1)
    p = rng.normal(size=(400, 3)) * 0.05
    n, off, eps = np.array([0.6, 0.8, 0.0]), 0.01, 0.01
    q = p - 2.0 * (p @ n - off)[:, None] * n
    d = np.linalg.norm(q[:, None, :] - p[None, :, :], axis=2).min(axis=1)
    cfg = CompletionConfig(support_eps=eps, support_samples=1000)
    assert plane_support(p, n, off, cfg) == pytest.approx(np.mean(d < eps))


def test_a_symmetric_cloud_supports_its_plane_and_not_a_turned_one():
    pts = _cylinder(arc=(-1.0, 1.0)).points  # symmetric about y = -0.05
    cfg = CompletionConfig()
    true = plane_support(pts, [0.0, 1.0, 0.0], -0.05, cfg)
    turned = plane_support(pts, [np.sin(0.5), np.cos(0.5), 0.0], -0.05, cfg)
    assert true > 0.8 and turned < 0.4
    index = SupportIndex(pts, cfg.support_samples)
    # The rivals are turned by 15-40 deg: the true plane's support is the best there is.
    assert index.rival_support([0.0, 1.0, 0.0], -0.05, UP, cfg) < true


def test_rival_support_is_the_best_of_the_rival_planes_by_brute_force():
    pts = _box_corner().points
    cfg = CompletionConfig(rival_angles_deg=(-30.0, 20.0), rival_shift=0.01)
    idx = SupportIndex(pts, cfg.support_samples)
    n, off = np.array([1.0, -1.0, 0.0]) / math.sqrt(2), 0.0
    c = idx.subset.mean(axis=0)
    pivot = c - (c @ n - off) * n
    best = 0.0
    for deg in cfg.rival_angles_deg:
        a = math.radians(deg)
        r = np.array([[math.cos(a), -math.sin(a), 0], [math.sin(a), math.cos(a), 0], [0, 0, 1]])
        rn = r @ n
        for s in np.linspace(-0.01, 0.01, 5):
            best = max(best, plane_support(pts, rn, rn @ pivot + s, cfg))
    assert idx.rival_support(n, off, UP, cfg) == pytest.approx(best)


# ------------------------------------------------------------------------------- confidence --


@settings(max_examples=50, deadline=None)
@given(st.floats(0, 1), st.floats(0, 1), st.floats(0.01, 0.5), st.floats(0.01, 3.0))
def test_confidence_rises_with_support_and_falls_with_the_rivals(s, r, d, res):
    c = plane_confidence(s, r, res)
    assert 0.0 < c < 1.0
    assert plane_confidence(min(s + d, 1.0), r, res) >= c
    assert plane_confidence(s, min(r + d, 1.0), res) <= c


def test_confidence_dips_for_surfaces_nearly_of_revolution():
    # Supports of a typical view; the residual of a cup (0.13), a mug with its handle hidden or a
    # pitcher (0.2-0.3), a box (0.6-0.8); no axis counts as the clip's end.
    c = {r: plane_confidence(0.3, 0.3, r) for r in (0.13, 0.25, 0.7, 2.0)}
    assert c[0.25] < c[0.13] and c[0.25] < c[0.7] <= c[2.0]
    assert plane_confidence(0.3, 0.3, math.inf) == c[2.0] == plane_confidence(0.3, 0.3, math.nan)
    # The model as written in its docstring, by hand.
    m = CONFIDENCE_MODEL
    a = math.log(0.25)
    z = (m["bias"] + m["w_support"] * math.log(0.32) + m["w_rival"] * math.log(0.32)
         + m["w_axis"] * a + m["w_axis2"] * a * a)  # fmt: skip
    assert c[0.25] == pytest.approx(1 - 1 / (1 + math.exp(-z)))


def test_confidence_of_nan_is_nan():
    assert math.isnan(plane_confidence(math.nan, 0.3, 0.2))


def test_roc_auc_against_pairs_counted_by_hand():
    scores = np.array([0.9, 0.8, 0.3, 0.5, 0.5, 0.1])
    bad = np.array([False, False, False, True, False, True])
    pairs = [(g, b) for g in scores[~bad] for b in scores[bad]]
    want = np.mean([1.0 if g > b else 0.5 if g == b else 0.0 for g, b in pairs])
    assert roc_auc(scores, bad) == pytest.approx(want)
    assert math.isnan(roc_auc(scores, np.zeros(6, bool)))
    assert math.isnan(roc_auc([0.1, math.nan], [True, False]))


# ------------------------------------------------------------------------------- revolution --


def test_axis_of_a_cylinder_arc_is_found_and_a_box_is_not_rotational():
    fit = fit_revolution(_cylinder(), UP)
    np.testing.assert_allclose(fit.point[:2], [0.1, -0.05], atol=1e-6)
    assert fit.radius == pytest.approx(0.04) and fit.residual < 1e-6 and fit.rotational
    box = fit_revolution(_box_corner(), UP)
    assert not box.rotational and box.residual > 0.3
    face = _box_corner()
    one_face = OrientedPoints(*(x[face.normals[:, 1] < 0] for x in dataclasses.astuple(face)))
    flat = fit_revolution(one_face, UP)  # parallel normal lines: no axis at all
    assert not flat.rotational and math.isinf(flat.residual)


def test_revolving_puts_every_copy_on_the_same_radius_and_keeps_a_handle_once():
    cyl = _cylinder(arc=(-1.0, 1.0), n=1000)
    handle = OrientedPoints(
        np.array([[0.1 + 0.07, -0.05, 0.05]] * 20), np.tile([1.0, 0, 0], (20, 1)), np.ones(20),
        np.zeros(20, bool),
    )  # fmt: skip
    parts = zip(dataclasses.astuple(cyl), dataclasses.astuple(handle), strict=True)
    both = OrientedPoints(*(np.concatenate(x) for x in parts))
    fit = fit_revolution(cyl, UP)
    keep = profile_consistent(both, fit, 0.004)
    assert keep[:1000].all() and not keep[1000:].any()
    out = revolve(both, fit, 6)
    assert len(out) == 1020 + 5 * 1000 and out.mirrored.sum() == 5000
    r = np.hypot(out.points[:, 0] - 0.1, out.points[:, 1] + 0.05)
    np.testing.assert_allclose(r[out.mirrored], 0.04, atol=1e-9)
    # Normals turn with their points: still radial.
    radial = (out.points[:, :2] - [0.1, -0.05]) / r[:, None]
    np.testing.assert_allclose(np.sum(radial * out.normals[:, :2], axis=1)[out.mirrored], 1.0)
    with pytest.raises(DegenerateGeometryError):
        revolve(both, fit, 1)


def test_a_revolved_arc_meshes_to_the_whole_cylinder():
    cyl = _cylinder(arc=(-1.2, 1.2), n=4000)
    out = revolve(cyl, fit_revolution(cyl, UP), 8)
    mesh = poisson_reconstruct(out.points, out.normals, out.weights, table=TablePlane.horizontal())
    r = np.hypot(mesh.vertices[:, 0] - 0.1, mesh.vertices[:, 1] + 0.05)
    side = (mesh.vertices[:, 2] > 0.02) & (mesh.vertices[:, 2] < 0.08)
    assert abs(np.median(r[side]) - 0.04) < 0.003
    # All the way round, not just the seen arc.
    ang = np.arctan2(mesh.vertices[side, 1] + 0.05, mesh.vertices[side, 0] - 0.1)
    assert np.histogram(ang, bins=12, range=(-np.pi, np.pi))[0].min() > 0


# ------------------------------------------------------------------------------- the choice --


@pytest.fixture(scope="module")
def primitive_views():
    obs = [_scenes.view(kind, 0.4, noise=0.001, seed=1)[0] for kind in ("cylinder", "box")]
    return obs, search_batch(obs)


def test_a_cylinder_is_revolved_and_a_box_mirrored(primitive_views):
    obs, res = primitive_views
    cyl = choose_completion(res[0], obs[0])
    assert cyl.kind == "revolution" and "rotational" in cyl.reason and cyl.oriented is not None
    box = choose_completion(res[1], obs[1])
    assert box.kind == "mirror" and box.revolution.residual > 0.17 and box.mesh is None
    assert 0.0 < box.confidence < 1.0 and f"{box.confidence:.2f}" in box.reason
    assert box.flagged == (box.confidence < 0.5)


def test_the_modes_force_their_completion(primitive_views):
    obs, res = primitive_views
    paper = choose_completion(res[0], obs[0], CompletionConfig(mode="mirror"))
    assert paper.kind == "mirror" and paper.oriented.mirrored.any()
    fb = choose_completion(res[1], obs[1], CompletionConfig(mode="fallback", fallback="hull"))
    assert fb.kind == "fallback" and fb.oriented is None and fb.mesh.is_watertight
    # The hull reaches down to the table and holds every observed point.
    assert fb.mesh.bounds[0, 2] == pytest.approx(obs[1].table.offset, abs=1e-6)
    auto = choose_completion(res[1], obs[1], CompletionConfig(min_confidence=1.0, fallback="hull"))
    assert auto.kind == "fallback" and "<" in auto.reason


def test_the_support_fallback_mirrors_across_the_plane_it_names(primitive_views):
    from symjax.completion import supported_plane
    from symjax.symmetry import mirror_across

    obs, res = primitive_views
    c = choose_completion(res[1], obs[1])
    index = SupportIndex(c.visible, CompletionConfig().support_samples)
    # Any gain: the best-supported near-best plane replaces the mirror, and it is the one the
    # completion was mirrored across.
    cfg = CompletionConfig(mode="fallback", support_gain=0.0)
    plane = supported_plane(res[1], obs[1].table.normal, index, -1.0, cfg)
    fb = choose_completion(res[1], obs[1], cfg)
    assert plane is not None and fb.kind == "fallback" and fb.mesh is None
    want = mirror_across(res[1], obs[1], plane[0], plane[1])
    np.testing.assert_array_equal(
        fb.oriented.points, oriented_completion(want, obs[1].camera).points
    )
    assert f"support {plane[2]:.2f}" in fb.reason
    # A gain no plane reaches: the mirror is kept, and the reason says so.
    kept = choose_completion(res[1], obs[1], dataclasses.replace(cfg, support_gain=1.0))
    assert kept.kind == "mirror" and "the mirror is kept" in kept.reason


class _Grid:
    """A search result's first grid, as :func:`symjax.completion.grid_planes` reads it."""

    def __init__(self, votes, angles, shifts):
        self.votes, self.angles, self.shifts = votes, angles, shifts
        self.initial_axis = np.array([0.0, 1.0, 0.0])  # m0 = z x y = -x
        self.centroid = np.zeros(3)


def test_supported_plane_is_the_best_supported_of_the_near_best_votes():
    from symjax.completion import grid_planes, supported_plane

    rng = np.random.default_rng(0)
    # A cloud symmetric about x = 0.01 only.
    half = rng.uniform([0.0, -0.05, 0.0], [0.05, 0.05, 0.1], (1500, 3))
    pts = np.concatenate([half, half * [-1, 1, 1] + [0.02, 0, 0]])
    index = SupportIndex(pts, 3000)
    angles = np.radians([[-30.0, -10.0, 0.0, 10.0, 30.0]])
    shifts = np.array([-0.01, 0.0, 0.01])
    votes = np.array([[[5.0, 4.0, 6.0], [3.0, 2.0, 3.0], [2.9, 2.5, 2.8], [3.0, 2.0, 3.0],
                       [1.0, 1.5, 1.0]]])  # fmt: skip
    grid = _Grid(votes, angles, shifts)
    normals, offsets, _ = grid_planes(grid, UP)
    np.testing.assert_allclose(normals[0, 2], [-1.0, 0.0, 0.0], atol=1e-12)
    cfg = CompletionConfig(support_vote_ratio=3.0, support_gain=0.1)
    got = supported_plane(grid, UP, index, 0.0, cfg)
    # Brute force: the supports of every plane with a vote within 3x of the best (1.0).
    sup = {(j, k): index.support(normals[0, j], offsets[0, j, k], cfg.support_eps)
           for j in range(5) for k in range(3) if votes[0, j, k] <= 3.0}  # fmt: skip
    j, k = max(sup, key=sup.get)
    assert (j, k) == (2, 0)  # the plane x = 0.01: normal -x, offset -0.01
    assert got[1] == pytest.approx(offsets[0, 2, 0]) and got[2] == pytest.approx(sup[j, k])
    # The ratio keeps out planes with a worse vote, the gain planes that barely beat the found.
    assert (
        supported_plane(grid, UP, index, 0.0, dataclasses.replace(cfg, support_vote_ratio=2.0))[2]
        < got[2]
    )
    assert supported_plane(grid, UP, index, got[2] - 0.05, cfg) is None
    # A search that scored no plane has none to offer.
    unscored = _Grid(np.full_like(votes, np.inf), angles, shifts)
    assert supported_plane(unscored, UP, index, 0.0, cfg) is None


def test_footprint_hull_contains_the_points_and_their_shadow():
    # The top face of a box seen from above, one corner dipping under the table (noise); on a
    # table at z = 0 and on one 0.7 m up.
    pts = np.array([[0, 0, 0.1], [0.1, 0, 0.1], [0, 0.05, 0.1], [0.1, 0.05, 0.1], [0, 0, -0.01]])
    for z in (0.0, 0.7):
        hull = footprint_hull(pts + [0, 0, z], TablePlane.horizontal(z))
        assert hull.is_volume and hull.bounds[0, 2] == pytest.approx(z)
        assert hull.volume == pytest.approx(0.1 * 0.05 * 0.1)
    with pytest.raises(DegenerateGeometryError):
        footprint_hull(pts[:2], TablePlane.horizontal(0.0))


def test_a_batch_result_is_refused(primitive_views):
    obs, res = primitive_views
    with pytest.raises(ShapeError, match="index the batch"):
        choose_completion(res, obs[0])


@pytest.mark.parametrize(
    "kw",
    [
        {"mode": "mirrors"},
        {"support_eps": 0.0},
        {"support_eps": math.nan},
        {"rival_shift": -0.01},
        {"revolution_residual": 0.0},
        {"revolution_min_tilt": 1.5},
        {"revolution_copies": 1},
        {"min_confidence": 2.0},
        {"flag_below": -0.1},
        {"support_samples": 5},
        {"fallback": "box"},
        {"support_vote_ratio": 0.5},
        {"support_gain": 1.5},
    ],
)
def test_bad_completion_config_is_refused(kw):
    with pytest.raises(ConfigError):
        CompletionConfig(**kw)


# ------------------------------------------------------------------------- plausible shapes --


def test_the_distinct_plane_is_the_best_vote_far_enough_from_the_found_one(primitive_views):
    from symjax.completion import distinct_plane

    obs, res = primitive_views
    r = res[1]
    n, offset, vote = distinct_plane(r, obs[1].table.normal, 20.0)
    found = np.asarray(r.normal, float)
    assert np.degrees(np.arccos(min(1.0, abs(n @ found)))) >= 20.0 - 1e-6
    # Brute force over the first grid: the planes' normals from their angles, as the search does.
    s, t = np.asarray(r.initial_axis, float), np.asarray(obs[1].table.normal, float)
    m0 = np.cross(t, s)
    best = np.inf
    for i, j in np.ndindex(np.shape(r.angles)):
        a = float(np.asarray(r.angles)[i, j])
        m = math.cos(a) * m0 + math.sin(a) * np.cross(t, m0)
        if np.degrees(np.arccos(min(1.0, abs(m @ found)))) >= 20.0:
            best = min(best, float(np.asarray(r.votes)[i, j].min()))
    assert vote == pytest.approx(best)
    assert distinct_plane(r, obs[1].table.normal, 89.9) is None  # the fan spans +-20 deg


def test_plausible_shapes_of_a_box_weigh_the_found_mirror_most(primitive_views):
    from symjax import configs
    from symjax.completion import plausible_shapes
    from symjax.cycle.shapes import completed_meshes

    obs, res = primitive_views
    cfg = configs.load("study")
    box = plausible_shapes([obs[1]], cfg, search=search_batch([obs[1]]))[0]
    assert box.kinds == ("mirror", "alternative mirror", "fallback")
    c = choose_completion(res[1], obs[1])
    assert box.weights[0] == pytest.approx((1 + c.confidence) / 2, abs=1e-6)
    assert box.weights[1] == pytest.approx(box.weights[2]) and box.weights.sum() == pytest.approx(1)
    for m in box.meshes:
        assert m.is_watertight and m.bounds[0, 2] >= obs[1].table.offset - 1e-6
    # The first shape is the completion every other stage meshes.
    first = completed_meshes([obs[1]], [obs[1].table], cfg)[0]
    np.testing.assert_array_equal(box.meshes[0].vertices, first.vertices)
    one = dataclasses.replace(cfg, completion=CompletionConfig(shapes=1))
    assert len(plausible_shapes([obs[1]], one)[0]) == 1
