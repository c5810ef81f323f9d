"""Two touching objects of one height: cut where their tops meet level, and only there."""

from __future__ import annotations

import dataclasses

import cv2
import numpy as np
import pytest

from symjax import configs
from symjax.perception.level_tops import level_top_waists

CFG = configs.load("clutter").segmentation


def _two_lids(floating: bool = False, apart: float = 49.6):
    """Two 25-pixel lids at 10 cm, centres ``apart`` pixels apart (49.6: they meet in a waist 9
    pixels tall), each with its wall below its rim in the image down to the table (the right
    one's only down to 8 cm when ``floating``); where a wall meets the other wall or lid, it is
    cut already (a crease, a step)."""
    H, W = 120, 150
    rows, cols = np.mgrid[0:H, 0:W]
    centres = (40, 40), (40, 40 + apart)
    disc = [np.hypot(rows - r, cols - c) <= 25 for r, c in centres]
    mid = int(40 + apart / 2)
    wall = [
        (rows < 110) & (abs(cols - c) <= 25) & ~d & (rows > 40)
        for d, (_, c) in zip(disc, centres, strict=True)
    ]
    wall = [wall[0] & (cols < mid - 2), wall[1] & (cols > mid + 2)]
    low = (0.0, 0.08 if floating else 0.0)
    height = np.zeros((H, W))
    for k in (0, 1):
        height[wall[k]] = (low[k] + (0.1 - low[k]) * (110 - rows) / 70)[wall[k]]
    for k in (0, 1):
        height[disc[k]] = 0.1
    mask = disc[0] | disc[1] | wall[0] | wall[1]
    return mask, height, centres


def _pieces(mask, cut, centres):
    _, lab = cv2.connectedComponents((mask & ~cut).astype(np.uint8), connectivity=4)
    return [lab[int(r), int(c)] for r, c in centres]


def test_two_level_lids_are_cut_where_they_meet():
    mask, height, centres = _two_lids()
    assert cv2.connectedComponents(mask.astype(np.uint8), connectivity=4)[0] == 2
    cut = level_top_waists(mask, height, CFG)
    a, b = _pieces(mask, cut, centres)
    assert a != b and a > 0 and b > 0
    # The cut lies between the lids, not across them.
    cols = np.nonzero(cut)[1]
    assert cols.min() >= 55 and cols.max() <= 71, (cols.min(), cols.max())


@pytest.mark.parametrize(
    "case",
    [dict(floating=True), dict(apart=0), dict(off=True)],
    ids=["a-top-cut-from-its-body", "one-lid", "off"],
)
def test_what_stays_whole(case):
    mask, height, _ = _two_lids(case.get("floating", False), case.get("apart", 49.6) or 49.6)
    if case.get("apart") == 0:  # one lid: the left object alone
        mask &= np.arange(mask.shape[1])[None, :] < 66
    cfg = dataclasses.replace(CFG, level_top_px=0) if case.get("off") else CFG
    assert not level_top_waists(mask, height, cfg).any()


def test_two_cans_of_one_height_come_apart():
    # Clutter scene 146 of the 270 examined: a can against a box as high (tops 0.5 mm apart).
    from symjax.perception import segment
    from symjax.perception.clutter_benchmark import match_ious
    from symjax.perception.synthetic import clutter_scene

    kinds = ("box", "bottle", "box", "bottle", "can", "box", "bottle", "box")
    scene = clutter_scene(kinds, seed=306)
    for cfg, want in ((CFG, True), (dataclasses.replace(CFG, level_top_px=0), False)):
        result = segment(scene.depth, scene.camera, cfg)
        ious, _ = match_ious(scene.truth, result)
        assert (len(result) == len(kinds) and ious[4] >= 0.85) == want, (len(result), ious)
