"""A round object's wall splits off what lies beyond it: footprints given directly, two scenes."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from symjax import configs
from symjax.perception import segment
from symjax.perception.clutter_benchmark import match_ious
from symjax.perception.round_split import split_round_objects
from symjax.perception.synthetic import clutter_scene

CFG = configs.load("clutter").segmentation


def _part(rng, pieces, width=60):
    """One label (rows x ``width``) holding pieces of (footprints (n, 2), heights (n,)), each
    piece in columns of its own, left to right; returns labels, footprints and heights."""
    n = [len(h) for _, h in pieces]
    rows = -(-max(n) // (width // len(pieces)))
    foot = np.zeros((rows, width, 2))
    height = np.zeros((rows, width))
    labels = np.full((rows, width), -1, np.int32)
    cols = width // len(pieces)
    for i, (f, h) in enumerate(pieces):
        r, c = np.divmod(np.arange(len(h)), cols)
        foot[r, c + i * cols], height[r, c + i * cols] = f, h
        labels[r, c + i * cols] = 0
    return labels, foot, height


def _can(rng, r=0.035, n=1800):
    """A can seen from one side: its wall on half its circle up to 0.1 m (1 mm of noise), its
    lid inside the disc at the top."""
    t = rng.uniform(np.pi, 2 * np.pi, n)
    wall = r * np.stack([np.cos(t), np.sin(t)], 1) + rng.normal(0, 3e-4, (n, 2))
    lid = rng.uniform(-0.6 * r, 0.6 * r, (n // 3, 2))
    heights = np.concatenate([rng.uniform(0.0, 0.1, n), np.full(n // 3, 0.1)])
    return np.concatenate([wall, lid]), heights


def _face(rng, x0, x1, y, n=1500):
    """A box face: a segment along x at y, up to 0.12 m, its pixels in order along x (as in an
    image, where neighbouring pixels see neighbouring points)."""
    f = np.stack([np.sort(rng.uniform(x0, x1, n)), y + rng.normal(0, 3e-4, n)], 1)
    return f, rng.uniform(0.0, 0.12, n)


def test_a_box_face_tangent_to_a_can_is_split_off():
    # The face touches the can's circle at (0, -0.035) and runs away from it: no step, no
    # crease, one part; the face beyond the circle becomes a part of its own.
    rng = np.random.default_rng(0)
    labels, foot, height = _part(rng, [_can(rng), _face(rng, 0.005, 0.09, -0.035)])
    out = split_round_objects(labels, foot, height, CFG.min_cluster_points)
    assert out.max() == 1
    can, face = labels[:, :30] == 0, labels[:, 30:] == 0
    dist = np.linalg.norm(foot[:, 30:], axis=2)
    far = face & (dist > 0.045)  # the face's pixels clearly beyond the circle and its gap
    assert len(np.unique(out[:, :30][can])) == 1
    assert len(np.unique(out[:, 30:][far])) == 1 and out[:, :30][can][0] != out[:, 30:][far][0]


def test_a_can_alone_is_not_split():
    rng = np.random.default_rng(1)
    labels, foot, height = _part(rng, [_can(rng)], width=40)
    np.testing.assert_array_equal(split_round_objects(labels, foot, height, 100), labels)


@settings(max_examples=20, deadline=None)
@given(seed=st.integers(0, 2**16), a=st.floats(0.04, 0.12), b=st.floats(0.03, 0.1))
@example(seed=1, a=0.046875, b=0.03125)
def test_a_box_alone_is_not_split(seed, a, b):
    # Two faces at a right angle and the top between them: no arc of a round wall. (The example:
    # a circle grazes both faces of this small box, an arc of 152 deg with a gap of 27 deg that
    # holds the corner; split before the gap had to be empty.)
    rng = np.random.default_rng(seed)
    f1, h1 = _face(rng, 0.0, a, 0.0)
    f2, h2 = _face(rng, 0.0, b, 0.0)
    f2 = f2[:, ::-1]
    top = np.stack([rng.uniform(0, a, 800), rng.uniform(0, b, 800)], 1)
    yaw = rng.uniform(0, np.pi)
    rot = np.array([[np.cos(yaw), -np.sin(yaw)], [np.sin(yaw), np.cos(yaw)]])
    piece = (np.concatenate([f1, f2, top]) @ rot.T, np.concatenate([h1, h2, np.full(800, 0.12)]))
    labels, foot, height = _part(rng, [piece], width=40)
    np.testing.assert_array_equal(split_round_objects(labels, foot, height, 100), labels)


def test_a_wall_that_only_touches_a_circle_is_not_a_round_object():
    # A rounded, irregular wall (a scanned object): a third of it on a can's half circle, the
    # rest scattered inside that circle's ring, and a piece beyond: the wall inside the ring is
    # mostly not on the circle, so nothing is split (the YCB scans standing apart).
    rng = np.random.default_rng(2)
    f, h = _can(rng, n=600)
    inner = rng.uniform(0.012, 0.03, 1400)
    t = rng.uniform(np.pi, 2 * np.pi, 1400)
    scattered = inner[:, None] * np.stack([np.cos(t), np.sin(t)], 1)
    piece = (np.concatenate([f, scattered]), np.concatenate([h, rng.uniform(0, 0.07, 1400)]))
    labels, foot, height = _part(rng, [piece, _face(rng, 0.05, 0.09, -0.02, n=600)])
    np.testing.assert_array_equal(split_round_objects(labels, foot, height, 100), labels)


def _can_with_a_gap(rng, gap_deg):
    """:func:`_can` with no wall over ``gap_deg`` from 300 deg on (the stripe an occluder in front
    of it hides)."""
    f, h = _can(rng)
    t = np.degrees(np.arctan2(f[:, 1], f[:, 0])) % 360.0
    wall = np.arange(len(h)) < 1800
    keep = ~(wall & (t >= 300.0) & (t < 300.0 + gap_deg))
    return f[keep], h[keep]


@pytest.mark.parametrize(("gap", "flat", "split"), [
    (25.0, False, True),  # a wider gap: a piece that stands beside the wall is split off ...
    (25.0, True, False),  # ... a flat one (a neighbour's top) is not
    (10.0, True, True),  # with a narrow gap any piece is
    (40.0, False, False),  # no round object's wall has a gap that wide
])  # fmt: skip
def test_a_gap_in_the_wall_splits_only_a_walled_piece(gap, flat, split):
    rng = np.random.default_rng(3)
    f, h = _face(rng, 0.005, 0.09, -0.035)
    if flat:  # a sliver of a box's top at the can's lid height, beyond its circle
        f = np.stack([rng.uniform(0.045, 0.08, 1500), rng.uniform(-0.03, 0.0, 1500)], 1)
        h = np.full(1500, 0.1)
    labels, foot, height = _part(rng, [_can_with_a_gap(rng, gap), (f, h)])
    out = split_round_objects(labels, foot, height, CFG.min_cluster_points)
    assert (out.max() == 1) == split


@pytest.mark.parametrize(("seed", "kinds", "k"), [
    (99, ("box", "bottle", "can", "bottle", "can"), (0, 1)),
    (384, ("can", "box", "bottle", "bottle", "box", "bottle", "bottle", "box"), (6,)),
])  # fmt: skip
def test_scenes_with_a_round_object_joined_or_given_a_strip(seed, kinds, k, monkeypatch):
    # Clutter scenes 50 (a box and the bottle tangent to it were one object: IoU 0.49 and 0.18)
    # and 179 (a bottle took a strip of its neighbour: 0.83) of the 270 examined: whole with
    # round_objects, not without, and no object worse by more than a hundredth. (Without the
    # fragments and the necks too: in scene 179 each keeps the strip from the bottle as well.)
    import symjax.perception.round_parts as round_parts

    sc = clutter_scene(kinds, seed=seed)
    with monkeypatch.context() as patch:
        patch.setattr(round_parts, "neck_circle", lambda foot, height: None)
        before, _ = match_ious(sc.truth, segment(sc.depth, sc.camera, dataclasses.replace(
            CFG, round_objects=False, fragment_px=0)))  # fmt: skip
    res = segment(sc.depth, sc.camera, CFG)
    after, _ = match_ious(sc.truth, res)
    assert before[list(k)].max() < 0.85 <= after.min() and len(res) == len(kinds)
    assert np.all(after >= before - 0.01)


@pytest.mark.parametrize(("seed", "kinds", "k"), [
    (20009, ("bottle", "bottle", "box", "box", "can", "can"), (3, 5)),
    (20081, ("box", "box", "bottle", "bottle", "can"), (0, 4)),
])  # fmt: skip
def test_scenes_with_a_round_wall_seen_in_two_arcs(seed, kinds, k, monkeypatch):
    # Scenes 142 and 182 of the second sample: a can and the box face tangent to it were one
    # object; the can's wall on its circle has a gap of 27 and 19 deg, over :data:`_HOLE`.
    import symjax.perception.round_split as round_split

    sc = clutter_scene(kinds, seed=seed)
    res = segment(sc.depth, sc.camera, CFG)
    after, _ = match_ious(sc.truth, res)
    assert after.min() >= 0.85 and len(res) == len(kinds), after
    monkeypatch.setattr(round_split, "_WIDE_HOLE", round_split._HOLE)
    before, _ = match_ious(sc.truth, segment(sc.depth, sc.camera, CFG))
    assert before[list(k)].max() < 0.85, before
