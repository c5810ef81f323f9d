"""Pixels traded across a round part's wall go back: the wall's circle, the moves, a scene."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from symjax import configs
from symjax.perception import segment
from symjax.perception.clutter_benchmark import match_ious
from symjax.perception.round_parts import neck_circle, settle_round_parts, wall_circles
from symjax.perception.synthetic import clutter_scene

CFG = configs.load("clutter").segmentation


def _bottle(rng, centre, r, start, n=1500):
    """Footprint (N, 2) and heights (N,) of a bottle seen from one side: its wall on half the
    circle up to 0.1 m, its shoulder and neck inside the disc above."""
    t = rng.uniform(start, start + np.pi, n)
    wall = centre + r * np.stack([np.cos(t), np.sin(t)], 1) + rng.normal(0, 3e-4, (n, 2))
    top = centre + rng.uniform(-0.7 * r, 0.7 * r, (n // 2, 2))
    foot = np.concatenate([wall, top])
    height = np.concatenate([rng.uniform(0.0, 0.1, n), rng.uniform(0.1, 0.14, n // 2)])
    return foot, height


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 2**16), r=st.floats(0.02, 0.05), start=st.floats(0, 2 * np.pi))
def test_wall_circle_of_a_bottle_is_its_body(seed, r, start):
    rng = np.random.default_rng(seed)
    centre = rng.uniform(-0.3, 0.3, 2)
    foot, height = _bottle(rng, centre, r, start)
    fits = wall_circles(foot, height, CFG.round_residual, CFG.round_margin)
    assert fits is not None
    for circle in fits:  # the algebraic and the geometric fit
        np.testing.assert_allclose(circle[0], centre, atol=1.5e-3)
        assert abs(circle[1] - r) < 1.5e-3


def test_on_short_arcs_the_algebraic_circle_errs_small_the_geometric_less():
    # A can 7 cm wide seen along 120 degrees of its wall with 1 mm of noise: Kasa's fit is
    # biased small by about 0.8 mm (which keeps moves into its disc safe); the geometric one
    # is within a few hundredths of a millimetre.
    r, errors = 0.035, []
    for seed in range(40):
        rng = np.random.default_rng(seed)
        t = rng.uniform(0, 2 * np.pi / 3, 600)
        foot = r * np.stack([np.cos(t), np.sin(t)], 1) + rng.normal(0, 1e-3, (600, 2))
        fits = wall_circles(foot, rng.uniform(0.0, 0.1, 600), CFG.round_residual, 0.004)
        assert fits is not None
        errors.append([fits[0][1] - r, fits[1][1] - r])
    algebraic, geometric = np.median(errors, axis=0)
    assert algebraic < -5e-4 and abs(geometric) < 0.1 * abs(algebraic)


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 2**16), a=st.floats(0.03, 0.09), b=st.floats(0.0, 0.09))
def test_a_box_wall_is_not_round(seed, a, b):
    # Two faces at a right angle (one where b is small): straight lines, fitted by no circle.
    rng = np.random.default_rng(seed)
    u = np.concatenate([rng.uniform(0, a, 1000), np.zeros(int(1000 * b / 0.09) + 1)])
    v = np.concatenate([np.zeros(1000), rng.uniform(0, b, int(1000 * b / 0.09) + 1)])
    yaw = rng.uniform(0, np.pi)
    rot = np.array([[np.cos(yaw), -np.sin(yaw)], [np.sin(yaw), np.cos(yaw)]])
    foot = np.stack([u, v], 1) @ rot.T + rng.normal(0, 3e-4, (len(u), 2))
    height = rng.uniform(0.0, 0.12, len(u))
    assert wall_circles(foot, height, CFG.round_residual, CFG.round_margin) is None


def _two_parts():
    """Labels (20, 40): a bottle (label 0, columns 0-19) and a box (label 1, columns 20-39)
    side by side, with the pixels' footprints and heights given directly."""
    rng = np.random.default_rng(3)
    labels = np.repeat(np.repeat(np.array([[0, 1]], np.int32), 20, axis=1), 20, axis=0)
    foot = np.zeros((20, 40, 2))
    height = np.zeros((20, 40))
    f, h = _bottle(rng, np.array([0.0, 0.0]), 0.04, 0.0, n=300)
    pick = rng.permutation(len(f))[:400]
    foot[:, :20] = f[pick].reshape(20, 20, 2)
    height[:, :20] = h[pick].reshape(20, 20)
    # The box's near face: a segment beside the bottle, x from 0.05 to 0.12 at y = 0.03.
    foot[:, 20:, 0] = rng.uniform(0.05, 0.12, (20, 20))
    foot[:, 20:, 1] = 0.03 + rng.uniform(-0.02, 0.0, (20, 20))
    height[:, 20:] = rng.uniform(0.0, 0.1, (20, 20))
    return labels, foot, height, np.ones((20, 40))


def test_a_neighbour_gives_back_what_lies_inside_a_round_disc():
    labels, foot, height, depth = _two_parts()
    # The box took two rows of the bottle's shoulder: footprints well inside the bottle's disc.
    foot[:2, 20:] = np.random.default_rng(4).uniform(-0.02, 0.02, (2, 20, 2))
    out = settle_round_parts(labels, foot, height, depth, CFG)
    assert (out[:2, 20:] == 0).all() and (out[2:, 20:] == 1).all() and (out[:, :20] == 0).all()


def test_a_round_part_gives_back_what_stands_in_a_neighbours_footprint():
    labels, foot, height, depth = _two_parts()
    # The bottle took a strip of the box face (beyond its circle, in the box's footprint) and
    # has a handle (beyond its circle, in no one's footprint): the strip goes, the handle stays.
    foot[:, 18, 0], foot[:, 18, 1] = np.linspace(0.052, 0.07, 20), 0.025
    foot[:, 19, 0], foot[:, 19, 1] = -0.055, np.linspace(-0.01, 0.01, 20)
    height[:, 18:20] = 0.05
    out = settle_round_parts(labels, foot, height, depth, CFG)
    bottle, box = out[0, 0], out[0, 39]  # renumbered by size: the box is now the larger
    assert (box, bottle) == (0, 1)
    assert (out[:, 18] == box).all() and (out[:, 19] == bottle).all()
    assert (out[:, :18] == bottle).all() and (out[:, 20:] == box).all()


def test_nothing_moves_between_parts_apart_or_without_round_walls():
    labels, foot, height, depth = _two_parts()
    apart = labels.copy()
    apart[:, 18:22] = -1  # no longer touching
    foot[:2, 20:] = 0.0  # inside the bottle's disc, but the parts do not touch
    np.testing.assert_array_equal(settle_round_parts(apart, foot, height, depth, CFG), apart)
    boxes = np.where(labels >= 0, labels, -1)
    flat = foot.copy()
    flat[:, :20, 1] = 0.06  # the "bottle" is a straight face now
    np.testing.assert_array_equal(settle_round_parts(boxes, flat, height, depth, CFG), labels)


@pytest.mark.parametrize(("seed", "kinds", "k"), [
    (33, ("bottle", "can", "bottle", "can", "bottle", "box", "can"), 2),
    (29, ("bottle", "box", "bottle", "bottle", "box", "bottle", "box"), 1),
])  # fmt: skip
def test_coplanar_shoulders_and_grazing_faces_go_back(seed, kinds, k):
    # Clutter benchmark scenes 17 (two bottles' shoulders at one height) and 13 (a box took a
    # bottle's shoulder): under 0.85 without, at least 0.85 with, and no object worse by more
    # than a hundredth.
    # (Measured before the round objects' split, which now mends scene 17 on its own.)
    sc = clutter_scene(kinds, seed=seed)
    on = dataclasses.replace(CFG, round_objects=False)
    off = dataclasses.replace(on, round_margin=0.0)
    before, _ = match_ious(sc.truth, segment(sc.depth, sc.camera, off))
    after, _ = match_ious(sc.truth, segment(sc.depth, sc.camera, on))
    assert before.min() < 0.85 <= after.min()
    assert np.all(after >= before - 0.01)
    assert match_ious(sc.truth, segment(sc.depth, sc.camera, CFG))[0].min() >= 0.85


def test_a_few_millimetres_wide_circle_is_no_wall(monkeypatch):
    # Most wall points of a part on a 3 mm ring, the rest scattered within 6.5 mm of its centre
    # (a strip seen at a grazing angle, noisy): least squares fit the ring, within the residual,
    # but the points within the margin of it span twice its diameter, so it is no wall's (the
    # settling moved a can's own pixels beyond such circles to its neighbours: 3 scenes of 270).
    import symjax.perception.round_parts as rp

    rng = np.random.default_rng(0)
    t = rng.uniform(0, 2 * np.pi, 1600)
    ring = 0.003 * np.stack([np.cos(t), np.sin(t)], 1) + rng.normal(0, 2e-4, (1600, 2))
    a, r = rng.uniform(0, 2 * np.pi, 400), 0.0065 * np.sqrt(rng.uniform(0, 1, 400))
    foot = np.concatenate([ring, r[:, None] * np.stack([np.cos(a), np.sin(a)], 1)])
    height = rng.uniform(0.0, 0.1, len(foot))
    monkeypatch.setattr(rp, "_SPAN", 0.0)
    small = wall_circles(foot, height, CFG.round_residual, CFG.round_margin)
    assert small is not None and small[0][1] < 0.005  # what the fit gives
    monkeypatch.undo()
    assert wall_circles(foot, height, CFG.round_residual, CFG.round_margin) is None


def _all_whole(kinds, seed) -> bool:
    sc = clutter_scene(kinds, seed=seed)
    result = segment(sc.depth, sc.camera, CFG)
    ious, _ = match_ious(sc.truth, result)
    return len(result) == len(kinds) and ious.min() >= 0.85


@pytest.mark.parametrize(("kinds", "seed", "off"), [
    (("bottle", "can", "can", "box", "can"), 567, ("geometric",)),
    (("box", "can", "can", "box", "box", "box", "can"), 455, ("geometric", "beyond")),
    (("box", "box", "bottle", "box", "box", "box"), 360, ("beyond",)),
], ids=["scene-269", "scene-214", "scene-170"])  # fmt: skip
def test_a_round_part_gives_away_only_what_stands_beyond_its_wall(kinds, seed, off, monkeypatch):
    # Clutter scenes 269 and 214: a can (3.5 and 3.0 cm) touches another whose wall is too
    # short for a circle. Its algebraic circle is 5.0 and 5.6 mm too small, so its own edge
    # stood beyond it, within the other can's footprint, and went to it (IoU 0.81 and 0.82).
    # Scene 170: a box part passed for round with 31 % of its pixels beyond the circle, which
    # went to three neighbours (1,200 pixels, none theirs). 214 is mended by either change.
    import symjax.perception.round_parts as rp

    assert _all_whole(kinds, seed)
    if "geometric" in off:
        monkeypatch.setattr(rp, "_geometric_circle", lambda points, start: start)
    if "beyond" in off:
        monkeypatch.setattr(rp, "_BEYOND", 1.0)
    assert not _all_whole(kinds, seed)


def _necked_bottle(rng, centre, r, arc, n=1200, noise=1e-3):
    """Footprint (N, 2) and heights (N,) of a bottle seen over ``arc`` radians of its wall (up to
    0.1 m, with ``noise`` m), its shoulder ring at 0.1 m on the near side, and its neck (0.4 r)
    up to 0.14 m: the wall of its front half and its top."""
    t = rng.uniform(0.0, arc, n)
    wall = centre + r * np.stack([np.cos(t), np.sin(t)], 1) + rng.normal(0, noise, (n, 2))
    a, rho = rng.uniform(0.0, arc, n // 3), rng.uniform(0.4 * r, r, n // 3)
    ring = centre + rho[:, None] * np.stack([np.cos(a), np.sin(a)], 1)
    a = rng.uniform(0.0, np.pi, n // 4)
    neck = centre + 0.4 * r * np.stack([np.cos(a), np.sin(a)], 1)
    a, rho = rng.uniform(0, 2 * np.pi, n // 4), 0.4 * r * np.sqrt(rng.uniform(0, 1, n // 4))
    tip = centre + rho[:, None] * np.stack([np.cos(a), np.sin(a)], 1)
    foot = np.concatenate([wall, ring, neck, tip])
    height = np.concatenate([rng.uniform(0.0, 0.1, n), np.full(n // 3, 0.1),
                             rng.uniform(0.1, 0.14, n // 4), np.full(n // 4, 0.14)])  # fmt: skip
    return foot, height


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 2**16), r=st.floats(0.025, 0.045), arc=st.floats(0.6, np.pi))
def test_neck_circle_of_a_bottle_is_its_body(seed, r, arc):
    rng = np.random.default_rng(seed)
    centre = rng.uniform(-0.3, 0.3, 2)
    foot, height = _necked_bottle(rng, centre, r, arc)
    circle = neck_circle(foot, height)
    # (the top's points include the rim of the neck's near wall: a bias of 1-2 mm towards it)
    assert circle is not None
    assert np.linalg.norm(circle[0] - centre) < 3e-3 and abs(circle[1] - r) < 3e-3


def test_on_a_short_arc_the_neck_circle_holds_where_a_free_fit_is_centimetres_off():
    # 35 degrees of a 3.5 cm wall with 1 mm of noise, as a bottle beside its neighbours shows
    # it (fresh clutter scenes: free circles of 9-25 mm for bottles of 31-39 mm).
    errors = []
    for seed in range(20):
        rng = np.random.default_rng(seed)
        foot, height = _necked_bottle(rng, np.zeros(2), 0.035, 0.6)
        fits = wall_circles(foot, height, CFG.round_residual, CFG.round_margin)
        neck = neck_circle(foot, height)
        free = np.inf if fits is None else abs(fits[0][1] - 0.035)
        errors.append([free, abs(neck[1] - 0.035)])
    free, neck = np.median(errors, axis=0)
    assert free > 5e-3 and neck < 1e-3


@pytest.mark.parametrize("kind", ["can", "box"])
def test_a_can_or_a_box_has_no_neck(kind):
    rng = np.random.default_rng(1)
    if kind == "can":  # its lid is as wide as its wall
        foot, height = _bottle(rng, np.zeros(2), 0.035, 0.0)
        a, rho = rng.uniform(0, 2 * np.pi, 600), 0.035 * np.sqrt(rng.uniform(0, 1, 600))
        foot = np.concatenate([foot, rho[:, None] * np.stack([np.cos(a), np.sin(a)], 1)])
        height = np.concatenate([np.minimum(height, 0.1), np.full(600, 0.1)])
    else:  # two faces at a right angle and the top between them
        u, v = rng.uniform(0, 0.08, 800), rng.uniform(0, 0.05, 800)
        face = np.concatenate([np.stack([u, 0 * u], 1), np.stack([0 * v, v], 1)])
        top = np.stack([rng.uniform(0, 0.08, 800), rng.uniform(0, 0.05, 800)], 1)
        foot = np.concatenate([face, top])
        height = np.concatenate([rng.uniform(0.0, 0.1, 1600), np.full(800, 0.1)])
    assert neck_circle(foot, height) is None


def _bottle_beside_box():
    """Labels (20, 40): a necked bottle (label 0, columns 0-19, centre (0, 0), radius 4 cm)
    and a box face (label 1, columns 20-39) tangent to it at (0, 4.05 cm), 5 cm nearer the
    camera (a depth step: the parts touch but do not meet on one surface)."""
    rng = np.random.default_rng(5)
    labels = np.repeat(np.repeat(np.array([[0, 1]], np.int32), 20, axis=1), 20, axis=0)
    foot, height = np.zeros((20, 40, 2)), np.zeros((20, 40))
    f, h = _necked_bottle(rng, np.zeros(2), 0.04, np.pi, noise=3e-4)
    pick = rng.permutation(len(f))[:400]
    foot[:, :20], height[:, :20] = f[pick].reshape(20, 20, 2), h[pick].reshape(20, 20)
    foot[:, 20:, 0] = 0.004 * np.arange(20)  # columns 20-22 within 2 mm of the wall
    foot[:, 20:, 1] = 0.0405
    height[:, 20:] = rng.uniform(0.0, 0.1, (20, 20))
    depth = np.where(np.arange(40) < 20, 1.05, 1.0)[None, :].repeat(20, axis=0)
    return labels, foot, height, depth


def test_a_neighbour_gives_back_what_it_took_within_a_neck_circle_across_a_depth_step():
    labels, foot, height, depth = _bottle_beside_box()
    assert neck_circle(foot[:, :20].reshape(-1, 2), height[:, :20].ravel()) is not None
    # The box took a piece of the shoulder ring: rows 0-2 of columns 30-39.
    a = np.random.default_rng(6).uniform(0.3, 1.2, (3, 10))
    rho = np.random.default_rng(7).uniform(0.02, 0.04, (3, 10))
    foot[:3, 30:] = rho[..., None] * np.stack([np.cos(a), np.sin(a)], -1)
    height[:3, 30:] = 0.1
    out = settle_round_parts(labels, foot, height, depth, CFG)
    bottle, box = out[0, 0], out[10, 39]
    assert (out[:3, 30:] == bottle).all() and (out[:, :20] == bottle).all()
    # Its own face where it touches the wall, within the circle's slack, stays: it reaches
    # nowhere inside the circle.
    assert (out[3:, 20:] == box).all() and (out[:3, 20:30] == box).all()


def test_without_a_neck_nothing_moves_across_a_depth_step():
    labels, foot, height, depth = _bottle_beside_box()
    foot[:3, 30:] = 0.0  # inside the disc
    height[:, :20] = np.minimum(height[:, :20], 0.1)  # no neck: a can's lid at 0.1 m
    out = settle_round_parts(labels, foot, height, depth, CFG)
    np.testing.assert_array_equal(out, labels)


@pytest.mark.parametrize(("start", "moves"), [(-0.07, True), (-0.115, False)])
def test_a_bottle_gives_a_neighbour_the_piece_it_shows_on_its_other_side(start, moves):
    # The bottle holds a piece of the box's face seen on its other side, 2-7 cm beyond its
    # circle: it goes to the box when it comes within the bottle's width (8 cm) of the box's
    # footprint (4.5-7 cm here), and stays whole 9-11.5 cm away (no neighbour's).
    labels, foot, height, depth = _bottle_beside_box()
    foot[:, 20:, 1] += np.linspace(0.0, 0.02, 20)[:, None]  # the box's top, 2 cm deep
    piece = (slice(0, 3), slice(0, 10))
    foot[piece + (0,)] = np.linspace(start, start + 0.025, 10)[None, :]
    foot[piece + (1,)] = 0.0405
    height[piece] = 0.1
    circle = neck_circle(foot[:, :20].reshape(-1, 2), height[:, :20].ravel())
    assert circle is not None
    beyond = np.hypot(*(foot[piece] - circle[0]).reshape(-1, 2).T) - circle[1]
    assert beyond.min() > 0.015
    out = settle_round_parts(labels, foot, height, depth, CFG)
    bottle, box = out[10, 10], out[10, 39]
    assert (out[piece] == (box if moves else bottle)).all()
    rest = np.ones(labels.shape, bool)
    rest[piece] = False
    np.testing.assert_array_equal(out[rest] == box, labels[rest] == 1)


@pytest.mark.parametrize(("seed", "box", "bottle", "off"), [
    (10_029, 3, 1, (100, 200)),
    (10_167, 0, 1, (100, 200)),
    (10_410, 0, 3, (120, 220)),
    (10_415, 5, 1, (250, 400)),
])  # fmt: skip
def test_fresh_boxes_give_back_the_shoulder_rings_they_took(seed, box, bottle, off, monkeypatch):
    # Fresh clutter scenes (the draw from seed 10,000: its 15th, 82nd, 195th and 197th): a box
    # top meets a bottle's shoulder at one height and took its ring and the wall below it,
    # which put the box's symmetry plane 12-24 mm off. With necks the box keeps under 30 of the
    # bottle's pixels; without, it keeps ``off`` of them.
    import symjax.perception.round_parts as rp
    from symjax.perception.clutter_benchmark import fresh_scenes

    sc = fresh_scenes(1, seed)[0][1]
    for necks in (True, False):
        if not necks:
            monkeypatch.setattr(rp, "neck_circle", lambda foot, height: None)
        result = segment(sc.depth, sc.camera, CFG)
        ious, match = match_ious(sc.truth, result)
        held = int((result.objects[int(match[box])].mask & (sc.truth == bottle)).sum())
        if necks:
            assert held < 30 and ious[box] >= 0.95 and ious[bottle] >= 0.94
        else:
            assert off[0] <= held <= off[1]


def test_fresh_bottle_gives_back_the_box_face_seen_on_its_other_side(monkeypatch):
    # Fresh clutter scene 10,085 (the draw from seed 10,000: its 43rd): a bottle (truth 5)
    # stands in front of a box (truth 3) that touches it, and the box's face shows on both
    # sides of it. The creases left the far piece too few seeds for a part, and its band grew
    # from the bottle through the contact: 132 of the box's pixels, 2-6 cm beyond the bottle's
    # circle (166 in the bottle's mask), and the box's plane 39 deg off. Now they go back to the
    # box (measured: 34 left in the mask, the box's IoU 0.92 -> 0.97).
    import symjax.perception.round_parts as rp
    from symjax.perception.clutter_benchmark import fresh_scenes

    sc = fresh_scenes(1, 10_085)[0][1]
    for beyond in (True, False):
        if not beyond:
            monkeypatch.setattr(rp, "_NECK_BEYOND", np.inf)
        result = segment(sc.depth, sc.camera, CFG)
        ious, match = match_ious(sc.truth, result)
        held = int((result.objects[int(match[5])].mask & (sc.truth == 3)).sum())
        if beyond:
            assert held < 50 and ious[3] >= 0.95 and ious[5] >= 0.95
        else:
            assert 120 <= held <= 250 and ious[3] < 0.93
