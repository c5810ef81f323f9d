"""symjax.perception.depth_pixels: enclosed pixels, filled holes, objects' masks on their boxes and
the candidates' boxes against plain references."""

from __future__ import annotations

import cv2
import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.ndimage import binary_fill_holes

from symjax import configs
from symjax.observation import fill_mask
from symjax.perception.depth_pixels import candidate_boxes, enclosed, fill_holes, object_mask
from symjax.perception.object_info import UNCLAIMED_PX


def _rings(rng: np.random.Generator) -> np.ndarray:
    H, W = int(rng.integers(3, 60)), int(rng.integers(3, 60))
    m = np.zeros((H, W), np.uint8)
    for _ in range(int(rng.integers(1, 5))):
        centre = (int(rng.integers(0, W)), int(rng.integers(0, H)))
        cv2.circle(m, centre, int(rng.integers(1, 20)), 1, int(rng.integers(1, 4)))
    m = m.astype(bool) | (rng.random((H, W)) < rng.uniform(0.0, 0.3))
    m[int(rng.integers(0, H)), int(rng.integers(0, W))] = True  # never empty
    return m


@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 2**31 - 1))
def test_enclosed_is_scipys_fill_holes_in_the_masks_box(seed):
    rng = np.random.default_rng(seed)
    mask = _rings(rng)
    free = rng.random(mask.shape) < 0.8
    rows, cols = np.flatnonzero(mask.any(axis=1)), np.flatnonzero(mask.any(axis=0))
    box = (slice(rows[0], rows[-1] + 1), slice(cols[0], cols[-1] + 1))
    want = np.zeros_like(mask)
    want[box] = binary_fill_holes(mask[box]) & ~mask[box] & free[box]
    np.testing.assert_array_equal(enclosed(mask, free), want)


@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), passes=st.integers(0, 3))
def test_fill_holes_takes_the_nearest_depth_pass_by_pass(seed, passes):
    rng = np.random.default_rng(seed)
    depth = rng.uniform(0.5, 1.5, (int(rng.integers(2, 40)), int(rng.integers(2, 40))))
    depth = depth.astype(np.float32)
    depth[rng.random(depth.shape) < rng.uniform(0.0, 0.9)] = 0.0
    valid = depth > 0
    want = np.where(valid, depth, np.inf)
    for _ in range(passes):  # the smallest 3x3 neighbour (the edge repeated), empty pixels only
        p = np.pad(want, 1, mode="edge")
        H, W = want.shape
        near = np.min([p[r : r + H, c : c + W] for r in range(3) for c in range(3)], axis=0)
        want = np.where(np.isfinite(want), want, near)
    want = np.where(np.isfinite(want), want, 0.0)
    got = fill_holes(depth, valid, passes)
    np.testing.assert_array_equal(got, want.astype(np.float32))


@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), fill=st.sampled_from(["close", "hull", "none"]))
def test_object_mask_on_its_box_is_the_frames_fill(seed, fill):
    # Masks that reach the frame's border too: the closing pads there as on the frame.
    rng = np.random.default_rng(seed)
    own = _rings(rng)
    hw = own.shape
    extra = (rng.random(hw) < rng.uniform(0.0, 0.05)) & ~own
    ids, more = np.flatnonzero(own), np.flatnonzero(extra)
    box, measured, mask = object_mask(ids, more, hw, fill)
    got_measured, got_mask = np.zeros(hw, bool), np.zeros(hw, bool)
    got_measured[box], got_mask[box] = measured, mask
    np.testing.assert_array_equal(got_measured, own)
    np.testing.assert_array_equal(got_mask, fill_mask(own | extra, fill))


@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 2**31 - 1))
def test_candidate_boxes_hold_every_piece_that_can_be_an_object(seed):
    # Blobs and specks: the box of all is the candidates' box and a pixel; the pieces' box lies
    # in it and holds each 8-connected piece of UNCLAIMED_PX or more (the clutter preset's least)
    # with its margin, except where the box of all or the frame ends first.
    from scipy.ndimage import label

    rng = np.random.default_rng(seed)
    cand = _rings(rng) & (rng.random((1, 1)) < 0.9)
    cand |= rng.random(cand.shape) < rng.uniform(0.0, 0.02)  # the table's specks
    if not cand.any():
        cand[0, 0] = True
    cfg = configs.load("clutter").segmentation
    pieces, every = candidate_boxes(cand, cfg)
    H, W = cand.shape
    rows, cols = np.flatnonzero(cand.any(axis=1)), np.flatnonzero(cand.any(axis=0))
    assert every == (
        slice(max(rows[0] - 1, 0), min(rows[-1] + 2, H)),
        slice(max(cols[0] - 1, 0), min(cols[-1] + 2, W)),
    )
    comp, n = label(cand, np.ones((3, 3), bool))
    big = [k for k in range(1, n + 1) if (comp == k).sum() >= UNCLAIMED_PX]
    if not big:
        assert pieces is None
        return
    pad = 4 + max(cfg.crease_smooth_px // 2 + cfg.crease_scale_px, cfg.split_bridges_px, 5)
    r, c = np.nonzero(np.isin(comp, big))
    for got, lo, hi, outer in ((pieces[0], r.min(), r.max(), every[0]),
                               (pieces[1], c.min(), c.max(), every[1])):  # fmt: skip
        assert outer.start <= got.start and got.stop <= outer.stop
        assert got.start == max(lo - pad, outer.start)
        assert got.stop == min(hi + 1 + pad, outer.stop)
