"""symjax.perception.object_info: the occluders' depth image."""

from __future__ import annotations

import numpy as np

from symjax.perception.object_info import occluder_depth


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
