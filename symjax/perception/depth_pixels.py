"""Pixel-level steps of a depth frame's segmentation: viewing rays, holes, the table's extent,
the pixels an object's mask encloses."""

from __future__ import annotations

import numpy as np

from symjax.camera import Camera
from symjax.geometry import pixel_rays
from symjax.observation import CLOSE_PX, fill_mask
from symjax.perception.config import SegmentationConfig

__all__ = [
    "box_shift",
    "candidate_boxes",
    "enclosed",
    "fill_holes",
    "in_workspace",
    "object_mask",
    "pixel_rays_of",
    "table_hull",
]

#: Pixels around a pixel that the colour creases read (a 5 x 5 blur, Canny's 3 x 3 gradient and
#: its suppression, the 3 x 3 widening).
_COLOUR_PX = 5

_RAYS_CACHE: dict[tuple, np.ndarray] = {}


def pixel_rays_of(camera: Camera) -> np.ndarray:
    """Camera-frame rays (H, W, 3) with unit z, cached per intrinsics (frames share a camera)."""
    K = np.asarray(camera.K, np.float64)
    key = (K.tobytes(), camera.width, camera.height)
    if key not in _RAYS_CACHE:
        if len(_RAYS_CACHE) > 8:
            _RAYS_CACHE.clear()
        _RAYS_CACHE[key] = pixel_rays(K, camera.height, camera.width).astype(np.float32)
    return _RAYS_CACHE[key]


def in_workspace(points: np.ndarray, cfg: SegmentationConfig) -> np.ndarray | bool:
    """Which points (..., 3) lie in the configured workspace box (True when there is none)."""
    if cfg.workspace_min is None:
        return True
    lo = np.asarray(cfg.workspace_min, np.float32)
    hi = np.asarray(cfg.workspace_max, np.float32)
    return np.all((points >= lo) & (points <= hi), axis=-1)


def table_hull(on_table: np.ndarray) -> np.ndarray:
    """Convex hull (H, W) bool of the table pixels, from each row's outermost table pixels."""
    import cv2

    rows = np.flatnonzero(on_table.any(axis=1))
    W = on_table.shape[1]
    sub = on_table[rows]
    left = np.argmax(sub, axis=1)
    right = W - 1 - np.argmax(sub[:, ::-1], axis=1)
    pts = np.concatenate([np.stack([left, rows], 1), np.stack([right, rows], 1)]).astype(np.int32)
    hull = np.zeros(on_table.shape, np.uint8)
    cv2.fillConvexPoly(hull, cv2.convexHull(pts), 1)
    return hull > 0


def fill_holes(depth: np.ndarray, valid: np.ndarray, passes: int) -> np.ndarray:
    """Depth with small holes filled by the nearest (smallest) neighbouring depth."""
    import cv2

    if passes == 0 or valid.all():
        return depth
    big = np.float32(1e9)
    filled = np.where(valid, depth, big)
    kernel = np.ones((3, 3), np.uint8)
    # Only the pixels still empty change: a pass updates them, not the whole frame.
    empty = np.flatnonzero(~valid)
    flat = filled.reshape(-1)
    for _ in range(passes):
        # Erosion of a float image is the 3x3 minimum: the nearest surface around a hole.
        nearest = cv2.erode(filled, kernel, borderType=cv2.BORDER_REPLICATE)
        flat[empty] = nearest.reshape(-1)[empty]
        empty = empty[flat[empty] >= big]
    flat[empty] = 0.0
    return filled


def candidate_boxes(cand: np.ndarray, cfg: SegmentationConfig):
    """The boxes of the candidate pixels (H, W) bool, any: of those that can become or touch an
    object, with a margin for the local steps that read the pixels around them, and of all.

    A noisy table puts specks of a few candidate pixels all over the frame (the timed 640 x 480
    clutter frame's specks spread its candidates over 434 x 640 pixels, its objects over
    247 x 227), and every image step on the box scales with its area. An 8-connected piece of
    fewer pixels than the least an object's seeds, a fragment or an unclaimed surface needs can
    be none of them, so only the larger ones set the first box. Its margin exceeds the widest
    neighbourhood a step reads around a pixel (the crease concavity's smoothing and span, the
    colour image's blur and edges, the bridges' erosion), and the box lies within the box of all:
    each pixel of those pieces sees what it saw on the box of all candidates.

    Returns:
        ``(pieces, every)``: ``(rows, cols)`` slices into the frame; ``pieces`` is None where no
        piece can be an object.
    """
    import cv2

    from symjax.perception.object_info import UNCLAIMED_PX

    H, W = cand.shape
    rows, cols = np.flatnonzero(cand.any(axis=1)), np.flatnonzero(cand.any(axis=0))
    r0, c0 = max(int(rows[0]) - 1, 0), max(int(cols[0]) - 1, 0)
    every = (slice(r0, min(int(rows[-1]) + 2, H)), slice(c0, min(int(cols[-1]) + 2, W)))
    least = min(
        cfg.min_cluster_points,
        cfg.fragment_px if cfg.fragment_px > 0 else cfg.min_cluster_points,
        UNCLAIMED_PX if cfg.unclaimed_occluders else cfg.min_cluster_points,
    )
    # (on the box of all: a 1280 x 720 frame's labelling 4.2 -> 2 ms)
    _, _, stats, _ = cv2.connectedComponentsWithStats(
        np.ascontiguousarray(cand[every]).view(np.uint8), connectivity=8
    )
    stats = stats[1:][stats[1:, cv2.CC_STAT_AREA] >= least]
    if not len(stats):
        return None, every
    reach = max(cfg.crease_smooth_px // 2 + cfg.crease_scale_px, cfg.split_bridges_px, _COLOUR_PX)
    pad = 4 + reach
    x0, y0 = stats[:, 0].min() + c0, stats[:, 1].min() + r0
    x1, y1 = (stats[:, 0] + stats[:, 2]).max() + c0, (stats[:, 1] + stats[:, 3]).max() + r0
    # Within the box of all: its sides, where a piece comes that close, stay where they were.
    pieces = (
        slice(max(int(y0) - pad, every[0].start), min(int(y1) + pad, every[0].stop)),
        slice(max(int(x0) - pad, every[1].start), min(int(x1) + pad, every[1].stop)),
    )
    return pieces, every


def box_shift(box: tuple[slice, slice], dr: int, dc: int) -> tuple[slice, slice]:
    """A bounding box (row and column slices) moved by ``(dr, dc)`` pixels."""
    return slice(box[0].start + dr, box[0].stop + dr), slice(box[1].start + dc, box[1].stop + dc)


#: Pixels around an object's box in :func:`object_mask`: more than the closing's radius
#: (:func:`symjax.observation.fill_mask`), so that the closing on the box is the frame's.
_MASK_PAD = CLOSE_PX + 2


def object_mask(ids: np.ndarray, extra: np.ndarray, hw: tuple[int, int], fill: str):
    """An object's mask on its bounding box, not the frame: at 640 x 480 the frame-sized closings
    of 8 objects took 5.6 ms a frame, this 0.9 ms.

    Args:
        ids: Flat indices (N,) of the object's measured pixels in an (H, W) = ``hw`` frame.
        extra: Flat indices (M,) of the pixels it claims besides (dropouts), M may be 0.
        hw: The frame's shape.
        fill: The mask's fill (:func:`symjax.observation.fill_mask`).

    Returns:
        ``(box, measured, mask)``: the box (two slices into the frame, the pixels plus a margin),
        and on it (h, w) bool the measured pixels and the filled mask of both sets.
    """
    both = np.concatenate([ids, extra]) if len(extra) else ids
    rr, cc = np.divmod(both, hw[1])
    r0, c0 = max(int(rr.min()) - _MASK_PAD, 0), max(int(cc.min()) - _MASK_PAD, 0)
    r1, c1 = min(int(rr.max()) + 1 + _MASK_PAD, hw[0]), min(int(cc.max()) + 1 + _MASK_PAD, hw[1])
    rr, cc = rr - r0, cc - c0
    measured = np.zeros((r1 - r0, c1 - c0), bool)
    measured[rr[: len(ids)], cc[: len(ids)]] = True
    grown = measured.copy()
    grown[rr[len(ids) :], cc[len(ids) :]] = True
    return (slice(r0, r1), slice(c0, c1)), measured, fill_mask(grown, fill)


def enclosed(mask: np.ndarray, free: np.ndarray) -> np.ndarray:
    """The ``free`` pixels that ``mask`` encloses (holes of the mask), (H, W) bool.

    ``scipy.ndimage.binary_fill_holes`` within the mask's bounding box, as OpenCV's connected
    components: the pixels off the mask that no 4-connected path off the mask joins to the
    box's edge (the same pixels; scipy grows them by repeated dilation, ~10x slower).
    """
    import cv2

    rows, cols = np.flatnonzero(mask.any(axis=1)), np.flatnonzero(mask.any(axis=0))
    sl = (slice(rows[0], rows[-1] + 1), slice(cols[0], cols[-1] + 1))
    off = ~mask[sl]
    n, lab = cv2.connectedComponents(off.astype(np.uint8), connectivity=4, ltype=cv2.CV_32S)
    hole = np.ones(n, bool)
    hole[0] = False  # the mask itself
    hole[lab[0]] = hole[lab[-1]] = hole[lab[:, 0]] = hole[lab[:, -1]] = False
    out = np.zeros_like(mask)
    out[sl] = hole[lab] & free[sl]
    return out
