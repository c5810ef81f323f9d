"""symjax.perception.object_info: the occluders' depth image."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.ndimage import find_objects

from symjax.perception.object_info import _touches_border, occluder_depth


def test_occluder_depth_keeps_exactly_the_occluders_pixels():
    rng = np.random.default_rng(0)
    labels = rng.integers(-1, 6, (30, 40)).astype(np.int32)
    depth = rng.uniform(0.5, 1.0, (30, 40)).astype(np.float32)
    for occ in ((2,), (0, 5), (1, 3, 4)):
        got = occluder_depth(labels, depth, occ)
        assert got.dtype == np.float32
        np.testing.assert_array_equal(got, np.where(np.isin(labels, occ), depth, 0.0))
    assert not occluder_depth(labels, depth, ()).any()
    # An occluder label above every label in the image (a neighbour outside the crop).
    np.testing.assert_array_equal(occluder_depth(labels, depth, (9,)), np.zeros_like(depth))


@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), px=st.integers(0, 3))
def test_boxes_give_the_same_occluders_and_border_flags(seed, px):
    rng = np.random.default_rng(seed)
    H, W = int(rng.integers(4, 30)), int(rng.integers(4, 30))
    labels = np.full((H, W), -1, np.int32)
    for k in range(4):  # rectangles anywhere, some at the border, later ones on top
        r0, c0 = int(rng.integers(0, H)), int(rng.integers(0, W))
        labels[r0 : r0 + int(rng.integers(1, H)), c0 : c0 + int(rng.integers(1, W))] = k
    depth = rng.uniform(0.5, 1.0, (H, W)).astype(np.float32)
    boxes = find_objects(labels + 1, max_label=4)
    for occ in ((), (1,), (0, 3), (2, 9)):
        np.testing.assert_array_equal(
            occluder_depth(labels, depth, occ, boxes), occluder_depth(labels, depth, occ)
        )
    b = max(px, 1)
    for k, box in enumerate(boxes):
        if box is None:
            continue
        m = labels == k
        want = bool(m[:b].any() or m[-b:].any() or m[:, :b].any() or m[:, -b:].any())
        assert _touches_border(labels, k, box, px) == want
