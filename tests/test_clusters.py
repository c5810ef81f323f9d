"""symjax.perception.clusters against per-pixel numpy references."""

from __future__ import annotations

import numpy as np
import pytest

from symjax.perception import SegmentationConfig
from symjax.perception.clusters import _N8, grid_outliers


def _outliers_reference(depth, rays, labels, ratio):
    """The statistical outlier removal written pixel by pixel (8 neighbours, same label)."""
    H, W = labels.shape
    pts = rays * depth[..., None]
    mean, has, obj = {}, {}, []
    for r in range(H):
        for c in range(W):
            if labels[r, c] < 0:
                continue
            obj.append((r, c))
            d = [
                np.linalg.norm(pts[r + dr, c + dc] - pts[r, c])
                for dr, dc in _N8
                if 0 <= r + dr < H and 0 <= c + dc < W and labels[r + dr, c + dc] == labels[r, c]
            ]
            has[r, c] = bool(d)
            mean[r, c] = np.mean(d) if d else 0.0
    vals = np.array([mean[p] for p in obj if has[p]])
    out = np.zeros((H, W), bool)
    for p in obj:
        out[p] = not has[p] or (len(vals) >= 2 and mean[p] > vals.mean() + ratio * vals.std())
    return out


@pytest.mark.parametrize("seed", range(4))
def test_grid_outliers_match_the_pixel_by_pixel_reference(seed):
    rng = np.random.default_rng(seed)
    H, W = 17, 23
    labels = rng.integers(-1, 3, (H, W)).astype(np.int32)
    labels[:6, :8] = 0  # a block, so that most pixels have neighbours of their own label
    depth = (0.8 + 0.01 * rng.standard_normal((H, W))).astype(np.float32)
    depth[rng.random((H, W)) < 0.05] += 0.3  # flying pixels
    v, u = np.mgrid[:H, :W]
    rays = np.stack([(u - W / 2) / 500, (v - H / 2) / 500, np.ones((H, W))], -1).astype(np.float32)
    cfg = SegmentationConfig()
    got = grid_outliers(depth, rays, labels, cfg)
    want = _outliers_reference(depth.astype(np.float64), rays.astype(np.float64), labels,
                               cfg.sor_std_ratio)  # fmt: skip
    assert got.dtype == bool and got.shape == (H, W)
    # float32 sums against float64 ones: a pixel on the threshold may differ, no more.
    assert np.count_nonzero(got != want) <= 1
    assert got[labels >= 0].any()
    assert not got[labels < 0].any()


def test_grid_outliers_of_no_object_are_none():
    cfg = SegmentationConfig()
    labels = np.full((5, 6), -1, np.int32)
    out = grid_outliers(np.ones((5, 6), np.float32), np.ones((5, 6, 3), np.float32), labels, cfg)
    assert out.shape == (5, 6) and not out.any()
