"""Concave creases of a depth image: where two touching objects meet.

Objects that touch leave no depth step between them, but their surfaces meet in a valley: seen
from the camera the contact is concave, while an object's own edges (a box's corners, a can's
rim) are convex. This is the local-convexity cue of LCCP (Stein et al., CVPR 2014) computed on
the pixel grid: for each pixel and four image directions, the inverse depth of the pixels
``scale_px`` before and after it is compared with its own. Inverse depth is affine in the pixel
coordinates on any plane, so the second difference vanishes on flat faces whatever their slant,
and its sign tells valleys (the pixel lies beyond the chord of its neighbours) from ridges.
"""

from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor

import numpy as np

__all__ = ["colour_creases", "concavity", "crease_concavity", "crease_mask", "lab_image"]

# Image directions (drow, dcol) the second difference is taken along; diagonals span sqrt(2).
_DIRECTIONS = ((0, 1), (1, 0), (1, 1), (1, -1))


def _shift(a: np.ndarray, dr: int, dc: int) -> np.ndarray:
    """``out[r, c] = a[r + dr, c + dc]`` (0 outside)."""
    out = np.zeros_like(a)
    H, W = a.shape
    rs, re = max(0, -dr), min(H, H - dr)
    cs, ce = max(0, -dc), min(W, W - dc)
    out[rs:re, cs:ce] = a[rs + dr : re + dr, cs + dc : ce + dc]
    return out


def concavity(
    depth: np.ndarray,
    focal: float,
    scale_px: int = 5,
    smooth_px: int = 9,
    smooth_depth: float = 0.01,
    max_step: float = np.inf,
) -> np.ndarray:
    """How concave the surface is at each pixel, as seen from the camera.

    Args:
        depth: (H, W) metres along the optical axis, 0 = none.
        focal: Focal length, pixels.
        scale_px: Half span of the second difference, pixels.
        smooth_px: Diameter (pixels) of the edge-preserving (bilateral) filter applied first to
            average out the sensor noise; 0 = none.
        smooth_depth: Depth difference (m) the bilateral filter still averages across.
        max_step: A direction counts only where both samples lie within this depth (m) of the
            pixel: the far side of a large occluding step (a can behind a box) is no valley,
            and the step test cuts it already.

    Returns:
        float32 (H, W): the largest over four directions of the valley depth (the sagitta, m) over
        the half span (m) at the pixel's depth, ``~ tan`` of half the bend of a crease; <= 0 on
        ridges and flat faces, 0 where a neighbour has no depth.
    """
    import cv2

    z = np.asarray(depth, np.float32)
    if smooth_px:
        z = cv2.bilateralFilter(z, smooth_px, smooth_depth, smooth_px / 3) * (z > 0)
    # Products with masks where np.where would do: the values are finite, and np.where on an
    # unpredictable mask is several times slower (a 0 may come out as -0, which compares equal).
    w = (1.0 / np.maximum(z, 1e-6)) * (z > 0)
    # The samples before and after each pixel are views into zero-padded copies, and the terms
    # are formed in place: shifted copies and temporaries were most of the time (the same
    # arithmetic, so the same values).
    s, (H, W) = scale_px, z.shape
    wp, zp = np.pad(w, s), np.pad(z, s)

    def at(a: np.ndarray, dr: int, dc: int) -> np.ndarray:
        return a[s + dr * s : s + dr * s + H, s + dc * s : s + dc * s + W]

    w2 = 2.0 * w

    def largest(directions) -> np.ndarray:
        """The largest second difference over ``directions`` of one span."""
        top = None
        for dr, dc in directions:
            a, b = at(wp, -dr, -dc), at(wp, dr, dc)
            ok = (a > 0) & (b > 0)
            if np.isfinite(max_step):
                for zn in (at(zp, -dr, -dc), at(zp, dr, dc)):
                    step = zn - z
                    np.abs(step, out=step)
                    ok &= step < max_step
            d2 = a + b
            d2 -= w2
            d2 *= ok
            top = d2 if top is None else np.maximum(top, d2, out=top)
        return top

    # The largest second difference per span (axes, diagonals; the diagonals on a second core),
    # scaled once per span: the scale is positive, so the largest product is the product of the
    # largest difference.
    with ThreadPoolExecutor(1) as pool:
        diagonal = pool.submit(largest, _DIRECTIONS[2:])
        top = {float(scale_px): largest(_DIRECTIONS[:2])}
        top[scale_px * np.sqrt(2.0)] = diagonal.result()
    best = np.full(z.shape, -np.inf, np.float32)
    for span, d2 in top.items():
        # Sagitta z^2 * d2w / 2 over the half span z * span / f.
        np.maximum(best, d2 * (z * focal / (2.0 * span)), out=best)
    return best * (w > 0)


def crease_concavity(depth: np.ndarray, focal: float, config) -> np.ndarray:
    """:func:`concavity` with the ``crease_*`` settings of a
    :class:`symjax.perception.SegmentationConfig`."""
    return concavity(
        depth,
        focal,
        config.crease_scale_px,
        config.crease_smooth_px,
        config.crease_smooth_depth,
        max_step=config.crease_max_step,
    )


def crease_mask(k: np.ndarray, config) -> np.ndarray:
    """Pixels on a concave crease (bool (H, W)) from the concavity ``k`` (H, W), widened by a
    pixel so that the cuts close.

    Hysteresis as in Canny's edges: pixels over ``crease_weak * crease_threshold`` count where
    they connect to one over ``crease_threshold``, so a crease keeps going where the two faces
    meet at a shallower angle, while isolated noise does not cut.
    """
    import cv2

    weak = (k > config.crease_weak * config.crease_threshold).astype(np.uint8)
    n, lab = cv2.connectedComponents(weak, connectivity=8, ltype=cv2.CV_32S)
    strong = np.zeros(n, bool)
    strong[lab[k > config.crease_threshold]] = True
    strong[0] = False
    crease = strong[lab].astype(np.uint8)
    return cv2.dilate(crease, np.ones((3, 3), np.uint8)) > 0


def lab_image(rgb: np.ndarray) -> np.ndarray:
    """CIELAB (H, W, 3) float32 of an RGB uint8 image (L 0-100, a and b about -100..100): a
    colour difference of 1 is about the smallest one a person sees."""
    import cv2

    return cv2.cvtColor(np.asarray(rgb, np.float32) / 255.0, cv2.COLOR_RGB2Lab)


def colour_creases(lab: np.ndarray, k: np.ndarray, config) -> np.ndarray:
    """Colour edges (bool (H, W)) where the surface bends concavely, however little.

    Two objects that touch at a shallow angle leave a weak crease but usually a colour edge;
    a label's edge on a can lies on a convex surface and is not cut (``k <= colour_concavity``).
    Canny on each channel of the blurred CIELAB image, widened a pixel.
    """
    import cv2

    u8 = np.clip(cv2.GaussianBlur(lab, (5, 5), 1.2) * np.float32(2.0) + 128, 0, 255)
    u8[..., 0] = np.clip(lab[..., 0] * 2.55, 0, 255)
    edges = np.zeros(k.shape, bool)
    for c in range(3):
        edges |= cv2.Canny(np.ascontiguousarray(u8[..., c]).astype(np.uint8), 20, 40) > 0
    edges &= k > config.colour_concavity
    return cv2.dilate(edges.astype(np.uint8), np.ones((3, 3), np.uint8)) > 0
