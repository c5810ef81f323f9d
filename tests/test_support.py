"""Where crease-cut parts meet: the contact counts and height steps against a pixel loop."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from _pixel_pairs import pixel_pairs
from hypothesis import given, settings
from hypothesis import strategies as st

from symjax.perception.support import contacts


def _loop(labels, depth, max_step, height):
    n = int(labels.max(initial=-1)) + 1
    smooth, touch, rise = np.zeros((n, n), int), np.zeros((n, n), int), np.zeros((n, n))
    for a, b, p, q in pixel_pairs(labels):
        for x, y in ((a, b), (b, a)):
            touch[x, y] += 1
        if abs(depth[p] - depth[q]) < max_step:
            smooth[a, b] += 1
            smooth[b, a] += 1
            rise[a, b] += height[p] - height[q]
            rise[b, a] -= height[p] - height[q]
    return smooth, touch, rise


@settings(max_examples=25, deadline=None)
@given(
    st.integers(2, 9),
    st.integers(2, 9),
    st.integers(1, 4),
    st.integers(0, 2**31 - 1),
)
def test_contacts_match_a_pixel_loop(H, W, parts, seed):
    rng = np.random.default_rng(seed)
    labels = rng.integers(-1, parts, (H, W)).astype(np.int32)
    labels[0, 0] = parts - 1  # every label up to parts - 1 exists
    depth = rng.uniform(0.5, 0.52, (H, W)).astype(np.float32)
    height = rng.uniform(0.0, 0.2, (H, W)).astype(np.float32)
    got = contacts(labels, depth, 0.01, height)
    want = _loop(labels, depth, 0.01, height)
    np.testing.assert_array_equal(got[0], want[0])
    np.testing.assert_array_equal(got[1], want[1])
    np.testing.assert_allclose(got[2], want[2], atol=1e-5)
    np.testing.assert_allclose(got[2], -got[2].T)


def test_contacts_of_a_neck_on_its_shoulder():
    # A 2 x 4 neck (part 1) standing 5 mm above the shoulder row below it (part 0), and a
    # part 2 beside the shoulder behind a 3 cm depth step.
    labels = np.array([[-1, 1, 1, -1], [-1, 1, 1, -1], [0, 0, 0, 2]], np.int32)
    height = np.array([[0, 0.11, 0.11, 0], [0, 0.105, 0.105, 0], [0.1, 0.1, 0.1, 0.1]])
    depth = np.array([[0, 0.8, 0.8, 0], [0, 0.8, 0.8, 0], [0.8, 0.8, 0.8, 0.83]])
    smooth, touch, rise = contacts(labels, depth, 0.01, height)
    assert smooth[0, 1] == smooth[1, 0] == 2
    assert touch[0, 2] == 1 and smooth[0, 2] == 0
    np.testing.assert_allclose(rise[1, 0] / smooth[1, 0], 0.005)


def test_joined_contacts_are_the_contacts_of_the_joined_parts(monkeypatch):
    # join_supported keeps its pair counts up to date while it joins; on a clutter scene (its
    # bottles' necks join their shoulders) they equal a recount on the labels it returns.
    from symjax import configs
    from symjax.perception import segment, segmentation, support
    from symjax.perception.synthetic import clutter_scene

    seen = []

    def checked(labels, foot, height, config, depth=None, with_contacts=False):
        joined, smooth, touch = support.join_supported(labels, foot, height, config, depth, True)
        recount, retouch, _ = contacts(joined, depth, 0.5 * config.depth_jump, height)
        np.testing.assert_array_equal(smooth, recount)
        np.testing.assert_array_equal(touch, retouch)
        seen.append(int(labels.max()) - int(joined.max()))
        return (joined, smooth, touch) if with_contacts else joined

    monkeypatch.setattr(segmentation, "join_supported", checked)
    sc = clutter_scene(("bottle", "can", "bottle", "can", "bottle", "box", "can"), seed=33)
    segment(sc.depth, sc.camera, configs.load("clutter").segmentation)
    assert seen and seen[0] >= 2  # parts were joined


def _strip_beside_a_part(strip_top_row: int):
    """Labels, footprint, height and depth of a part 6 columns wide (0) and a strip 2 columns
    wide (1) beside it on one surface (no depth step), both from the table up: part 0 to
    9.6 cm, the strip to its top row (0: 17.4 cm). Footprints: part 0 covers 5 x 5 cm, the strip
    a line 1.45 cm long beside it."""
    H, W = 30, 8
    rows, cols = np.mgrid[0:H, 0:W]
    height = (H - 1 - rows) * 0.006
    labels = np.full((H, W), -1, np.int32)
    labels[13:, :6] = 0
    labels[strip_top_row:, 6:] = 1
    # The strip's footprint: a line, as a band of a box's side stands (not an arc: not round).
    x = np.where(cols < 6, cols * 0.01, 0.06 + (cols - 6) * 0.01 + (rows % 10) * 0.0005)
    y = np.where(cols < 6, (rows * 7) % 6 * 0.01, 0.0)
    foot = np.stack([x, y], axis=-1)
    depth = np.full((H, W), 0.8, np.float32)
    return labels, foot, height, depth


def test_a_narrow_strip_joins_its_neighbour_unless_it_towers_over_it():
    # A band of an object's side as tall as it joins it; a bottle's strip seen beside a can,
    # standing on the table and 8 cm taller, stays an object of its own.
    from symjax import configs
    from symjax.perception.support import join_supported

    config = configs.load("clutter").segmentation
    labels, foot, height, depth = _strip_beside_a_part(13)
    band = join_supported(labels, foot, height, config, depth)
    assert (band[labels >= 0] == 0).all()
    labels, foot, height, depth = _strip_beside_a_part(0)
    tower = join_supported(labels, foot, height, config, depth)
    assert tower.max() == 1
    assert len(np.unique(tower[labels == 1])) == 1 and tower[0, 6] != tower[29, 0]


def _neck_above(body: str):
    """A round neck (part 1, 12 mm radius, floating 15-20 cm high) above part 0 on one surface
    (no depth step): ``"strip"`` a narrow strip of a body around the neck's axis (an arc of
    33 mm radius, from the table up), ``"neighbour"`` a 5 cm wide object centred 10 cm away,
    ``"box"`` a 13 x 6 cm box whose footprint reaches under the neck's (its centre 6 cm away)."""
    H, W = 30, 8
    rows, cols = np.mgrid[0:H, 0:W]
    height = np.where(rows < 10, 0.20 - rows * 0.005, (H - 1 - rows) * 0.0075)
    labels = np.where(rows < 10, np.where(cols < 6, 1, -1), 0).astype(np.int32)
    t = np.pi * (rows * W + cols) / (H * W)  # spread over each part's pixels
    foot = np.stack([0.012 * np.cos(t * 3.0), -0.012 * np.sin(t * 3.0)], axis=-1)
    if body == "strip":
        a = np.pi / 3 + (t - t[10, 0]) / (t[-1, -1] - t[10, 0]) * np.pi / 3
        part0 = np.stack([0.033 * np.cos(a), -0.033 * np.sin(a)], axis=-1)
    elif body == "box":
        part0 = np.stack([0.13 * cols / (W - 1) - 0.01, 0.06 * (rows % 6) / 5 - 0.04], -1)
    else:
        part0 = np.stack([0.075 + 0.05 * (cols / (W - 1)), 0.05 * (rows % 6) / 5 - 0.025], -1)
    foot = np.where((rows >= 10)[..., None], part0, foot)
    return labels, foot, height, np.full((H, W), 0.8, np.float32)


def test_a_neck_joins_the_body_around_its_axis_not_a_neighbour():
    # A mostly hidden bottle shows its neck and shoulder above a neighbour it meets level; the
    # narrow-part rule gave them to that neighbour (3 scenes of 90), while a bottle's own neck
    # goes to the strip of its body below, whose footprint lies around the neck's axis.
    from symjax import configs
    from symjax.perception.support import join_supported

    config = configs.load("clutter").segmentation
    labels, foot, height, depth = _neck_above("strip")
    strip = join_supported(labels, foot, height, config, depth)
    assert (strip[labels >= 0] == 0).all()
    labels, foot, height, depth = _neck_above("neighbour")
    apart = join_supported(labels, foot, height, config, depth)
    assert apart.max() == 1 and apart[0, 0] != apart[29, 0]


def test_a_neck_over_a_neighbours_footprint_joins_it_only_around_its_axis():
    # A bottle's neck and shoulder behind a box, floating above it with the footprint at the
    # box's edge, stood on the box (the footprint rule; 3 scenes of 180); the box lies off the
    # neck's axis, while the neck's own body strip lies around it.
    from symjax import configs
    from symjax.perception.support import join_supported

    config = configs.load("clutter").segmentation
    labels, foot, height, depth = _neck_above("box")
    apart = join_supported(labels, foot, height, config, depth)
    assert apart.max() == 1 and apart[0, 0] != apart[29, 0]


@pytest.mark.parametrize(
    "scene",
    [
        # Clutter scenes of the 270 examined: a hidden bottle whose neck and upper shoulder were
        # cut from the arc of its lower shoulder seen between two bottles in front; 76 % of the
        # neck's footprint lies on the arc's hull (scene 14, with colour), 73 %-80 % in 221.
        (("box", "bottle", "box", "bottle", "bottle", "box"), 30, 3, True),
        (("box", "bottle", "can", "bottle", "bottle"), 466, 1, False),
    ],
    ids=["scene-14-colour", "scene-221"],
)
def test_a_hidden_neck_stands_on_the_arc_of_its_shoulder(scene, monkeypatch):
    import symjax.perception.support as support
    from symjax import configs
    from symjax.perception import segment
    from symjax.perception.clutter_benchmark import match_ious
    from symjax.perception.synthetic import clutter_scene

    kinds, seed, bottle, colour = scene
    sc = clutter_scene(kinds, seed=seed)
    # The share's own effect: in scene 221 the fragments (fragment_px) keep the bottle whole too.
    config = dataclasses.replace(configs.load("clutter").segmentation, fragment_px=0)
    # The shoulder's body strip under it would join it too (``_UNDER``): the share alone here.
    monkeypatch.setattr(support, "_UNDER", 0.0)
    for share, want in ((0.75, True), (0.8, False)):
        monkeypatch.setattr(support, "_ON_SUPPORT", share)
        result = segment(sc.depth, sc.camera, config, rgb=sc.rgb if colour else None)
        ious, _ = match_ious(sc.truth, result)
        whole = len(result) == len(kinds) and ious[bottle] >= 0.85
        assert whole == want, (share, len(result), ious)


def _shoulder_over_a_strip(strip_y: float, strip_top: float = 0.12):
    """A shoulder (part 1, rows 0-14, 18 down to 12.4 cm high, its footprint a 6 x 6 cm square)
    above a strip (part 0, rows 15-29, from ``strip_top`` down by 5.6 cm, its footprint a line
    6 cm long at y = ``strip_y`` m) 1 cm farther from the camera: they meet across a depth step,
    as a hidden bottle's shoulder meets the noisy edge of its body's strip."""
    H, W = 30, 8
    rows, cols = np.mgrid[0:H, 0:W]
    upper = rows < 15
    labels = np.where(upper, 1, 0).astype(np.int32)
    height = np.where(upper, 0.18 - rows * 0.004, strip_top - (rows - 15) * 0.004)
    x = cols * 0.0085
    foot = np.stack([x, np.where(upper, (rows % 6) * 0.012, strip_y)], axis=-1)
    depth = np.where(upper, 0.8, 0.81).astype(np.float32)
    return labels, foot, height, depth


@pytest.mark.parametrize(
    ("strip_y", "strip_top", "joins"),
    [(0.065, 0.12, True), (0.12, 0.12, False), (0.065, 0.07, False)],
    ids=["under-it", "6-cm-beyond-its-hull", "ending-5-cm-lower"],
)
def test_a_floating_shoulder_joins_the_strip_that_ends_under_it(strip_y, strip_top, joins):
    from symjax import configs
    from symjax.perception.support import join_supported

    config = configs.load("clutter").segmentation
    labels, foot, height, depth = _shoulder_over_a_strip(strip_y, strip_top)
    joined = join_supported(labels, foot, height, config, depth)
    assert (joined[0, 0] == joined[29, 0]) == joins


def test_scene_206_hidden_bottle_is_one_object(monkeypatch):
    # Clutter scene 206 of the 270 examined: bottle 3's shoulder, above box 2 in front, meets the
    # strip of its body beside the box along 19 pixel pairs, 2 of them without a depth step.
    import symjax.perception.support as support
    from symjax import configs
    from symjax.perception import segment
    from symjax.perception.clutter_benchmark import match_ious
    from symjax.perception.synthetic import clutter_scene

    kinds = ("box", "bottle", "box", "bottle", "bottle", "box")
    sc = clutter_scene(kinds, seed=433)
    config = configs.load("clutter").segmentation
    for under, want in ((0.03, True), (0.0, False)):
        monkeypatch.setattr(support, "_UNDER", under)
        result = segment(sc.depth, sc.camera, config)
        ious, _ = match_ious(sc.truth, result)
        assert (len(result) == len(kinds) and ious[3] >= 0.85) == want, (under, ious)


@pytest.mark.parametrize(
    ("kinds", "seed", "bottle", "box"),
    [
        (("can", "box", "bottle", "can", "bottle"), 10101, 2, 1),
        (("can", "box", "bottle", "box", "can", "can"), 20125, 2, 3),
    ],
    ids=["second-sample-52", "second-sample-207"],
)
def test_a_hidden_bottles_top_does_not_join_the_box_it_meets_from_above(
    kinds, seed, bottle, box, monkeypatch
):
    # Scenes 52 and 207 of the second sample (seeds 10,000 and 20,000 on): a bottle hidden
    # behind a can or a box shows its shoulder and neck, narrow as cut, meeting the box's top
    # from above without a depth step; it joined the box (IoU 0) although the box stands in
    # front of it, not under it. Without the footprint test (``_UNDER`` unbounded) it does so
    # again (measured without the fragments, which in scene 52 keep a piece off the box too).
    import symjax.perception.support as support
    from symjax import configs
    from symjax.perception import segment
    from symjax.perception.clutter_benchmark import match_ious
    from symjax.perception.synthetic import clutter_scene

    sc = clutter_scene(kinds, seed=seed)
    config = configs.load("clutter").segmentation
    result = segment(sc.depth, sc.camera, config)
    ious, _ = match_ious(sc.truth, result)
    assert len(result) == len(kinds) and ious.min() >= 0.85, ious
    monkeypatch.setattr(support, "_UNDER", np.inf)
    config = dataclasses.replace(config, fragment_px=0)
    ious, _ = match_ious(sc.truth, segment(sc.depth, sc.camera, config))
    assert ious[bottle] < 0.5 and ious[box] < 0.85, ious
