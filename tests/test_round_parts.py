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
from symjax.perception.round_parts import settle_round_parts, wall_circles
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
