"""symjax.perception.bridges: touching objects joined through a few pixels, split, and one
object nearly cut by noise creases kept whole (through ``image_clusters``)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from symjax.perception import SegmentationConfig
from symjax.perception.clusters import image_clusters


def _blobs(bridge_px: int, neck_px: int = 0, step: float = 0.03):
    """Two discs of radius 14 px that touch, the right one ``step`` metres behind the left, with
    a bridge ``bridge_px`` rows high where the depth ramps from one to the other in steps under
    the jump, and a neck ``neck_px`` wide standing on the left disc (a bottle's)."""
    H, W = 60, 80
    v, u = np.mgrid[:H, :W]
    left = (u - 22) ** 2 + (v - 40) ** 2 <= 14**2
    right = ((u - 49) ** 2 + (v - 40) ** 2 <= 14**2) & ~left
    depth = np.where(left, 0.8, np.where(right, 0.8 + step, 0.0))
    ramp = np.clip((u - 30) / 12.0, 0.0, 1.0) * step + 0.8
    depth[40 : 40 + bridge_px, 30:43] = ramp[40 : 40 + bridge_px, 30:43]
    if neck_px:
        depth[(np.abs(u - 22) <= neck_px // 2) & (v >= 8) & (v < 30)] = 0.8
    mask = depth > 0
    height = np.where(mask, 0.05, 0.0).astype(np.float32)
    return depth.astype(np.float32), height, mask


@pytest.mark.parametrize("bridge_px", [1, 2, 3])
def test_thin_bridge_between_two_objects_is_split(bridge_px):
    depth, height, mask = _blobs(bridge_px)
    cfg = SegmentationConfig(min_cluster_points=100)
    assert image_clusters(depth, height, mask, cfg).max() == 0  # one component without it
    cfg = dataclasses.replace(cfg, split_bridges_px=3)
    lab = image_clusters(depth, height, mask, cfg)
    assert lab.max() == 1
    # Every pixel keeps a label, and each disc's centre its own.
    assert (lab[mask] >= 0).all() and lab[40, 15] != lab[40, 55]


def test_a_bridge_within_one_surface_is_not_split():
    """Two parts that continue each other (no step where they meet: noise creases that nearly
    cut one object) stay one, however thin what joins them."""
    depth, height, mask = _blobs(2, step=0.0)
    cut = np.zeros_like(mask)
    cut[:40, 35:37] = cut[42:, 35:37] = True  # a crease across all but the bridge
    cfg = SegmentationConfig(min_cluster_points=100, split_bridges_px=3)
    lab = image_clusters(depth, height, mask, cfg, crease=cut)
    assert lab.max() == 0 and (lab[mask] >= 0).all()


def test_a_neck_wider_than_the_bridge_stays_with_its_body():
    depth, height, mask = _blobs(0, neck_px=12)
    cfg = SegmentationConfig(min_cluster_points=100, split_bridges_px=3)
    lab = image_clusters(depth, height, mask, cfg)
    assert lab.max() == 1  # the two discs, apart across their step
    assert lab[12, 22] == lab[40, 15]


def test_parts_along_a_colour_edge_stay_apart():
    """The smooth pair of the test above, with a colour crease along the crease too (objects
    that only colour tells apart): split at the bridge, and the split stands."""
    depth, height, mask = _blobs(2, step=0.0)
    cut = np.zeros_like(mask)
    cut[:40, 35:37] = cut[42:, 35:37] = True
    cfg = SegmentationConfig(min_cluster_points=100, split_bridges_px=3)
    lab = image_clusters(depth, height, mask, cfg, crease=cut, colour_crease=cut)
    assert lab.max() == 1 and lab[40, 15] != lab[40, 55]
    off = dataclasses.replace(cfg, split_bridges_px=0)
    assert image_clusters(depth, height, mask, off, crease=cut, colour_crease=cut).max() == 0


def test_parts_joined_back_are_numbered_by_size():
    depth, height, mask = _blobs(2, step=0.0)
    cut = np.zeros_like(mask)
    cut[:40, 35:37] = cut[42:, 35:37] = True
    cfg = SegmentationConfig(min_cluster_points=100, split_bridges_px=3)
    lab = image_clusters(depth, height, mask, cfg, crease=cut)
    assert sorted(np.unique(lab).tolist()) == [-1, 0]
