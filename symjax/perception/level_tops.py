"""Two touching objects of one height, apart where their tops meet level.

Two cans of one height side by side, or a can against a box as high, touch along a vertical line;
their walls meet there in a concave crease, but their tops meet level: one horizontal plane across
both, without a crease or a depth step, so the two come out as one object. Seen from above, the
two tops (a lid, a box top) form one plane region with a waist where they touch (two discs
touching at a point part by less than a pixel for about a centimetre either side). Eroding the
top region by a disc wider than the waist parts it into one core per top; the pixels where the
nearest core changes are cut, as a crease is, when each piece then reaches down to the table (two
objects standing on it; not the top of one object cut from its body), or when the cut is short, a
waist no wider than the erosion disc: an object half hidden behind the other one, whose visible
part does not reach the table, meets it there (a can behind a can of one height). A long cut is
the width of one top that noise eroded into two crumbs. The erosion tries a disc of ``level_top_px``
and then larger ones, keeping the first that parts the top.
"""

from __future__ import annotations

import numpy as np

from symjax.perception.config import SegmentationConfig

__all__ = ["level_top_waists"]

_TOP_BAND = 0.005  # m: the top region is the pixels within this of a part's top (98th percentile)
_MIN_TOP_PX = 300  # pixels: an eroded top core smaller than this is no object's top
_CUT_PX = 2  # pixels: the cut between two cores is widened by this (the walls below the rims)
_STANDS = 0.05  # m: each piece's 5th-percentile height is at most this (it stands on the table)
#: A cut of at most this many erosion radii in pixels parts two tops at a waist, standing or not
#: (on the 270 examined clutter scenes the right cuts were 3-18 pixels long at a radius of 6, the
#: wrong ones 23 and 44).
_WAIST_RADII = 3
#: Erosion radii tried in turn, in multiples of ``level_top_px``: on the 270 examined scenes the
#: larger ones parted four more pairs of tops (scenes 192, 217 and 251, a can's lid against a box
#: top, mended; 231 fails on another object) and cut nothing wrong.
_RADII = (1.0, 1.5, 2.0)


def _disk(r: int) -> np.ndarray:
    import cv2

    return cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * r + 1, 2 * r + 1))


def _least(r: int, first: int) -> float:
    """The smallest core (pixels) that erosion by a disc of radius ``r`` may leave of a top:
    :data:`_MIN_TOP_PX` at the first radius, where smaller crumbs are noise, and less in
    proportion to the disc's area beyond it, where any core means a wide disc fits in the top:
    a can's lid keeps 92-290 px at the 12 px disc that parts it from a box top (scenes 192 and
    251 of the 270 examined)."""
    return _MIN_TOP_PX * (first / r) ** 2


def _cores(top: np.ndarray, radii) -> tuple[np.ndarray, np.ndarray, np.ndarray, int]:
    """Erodes ``top`` (H, W) bool by discs of ``radii`` (pixels) in turn until two or more
    cores of at least :func:`_least` pixels are left.

    At each radius the top as measured is eroded first, then, if that leaves fewer than two
    cores, the top with its specks of noise filled: a lid whose heights scatter across the band
    erodes into crumbs (filled first, a speck in the waist between two tops would join them).

    Returns:
        ``(top, labels, cores, r)``: the top that was parted (filled or not), the eroded top's
        component labels (H, W), the labels of its cores (fewer than two: none parted it), and
        the radius that parted it.
    """
    import cv2

    filled = None
    cores, big, r = None, np.zeros(0, np.int64), 0
    shrunk = [False, False]  # per attempt: too little left to part at this radius or beyond
    for r in radii:
        for attempt in (0, 1):
            if shrunk[attempt]:
                continue
            if attempt and filled is None:
                # A speck's pixels have at least 7 of their 8 neighbours on the top (counted by
                # a box filter: labelling the gaps cost twice as much).
                count = cv2.boxFilter(top.astype(np.uint8), -1, (3, 3), normalize=False)
                filled = top | (count >= 7)
                shrunk[1] = np.array_equal(filled, top)  # no specks: nothing new to erode
                if shrunk[1]:
                    continue
            t = filled if attempt else top
            # Padded so that the crop's border erodes the top.
            core = cv2.erode(np.pad(t, r + 1).astype(np.uint8), _disk(r))[
                r + 1 : -r - 1, r + 1 : -r - 1
            ]
            if np.count_nonzero(core) < 2 * _least(radii[-1], radii[0]):
                shrunk[attempt] = True  # a larger disc leaves less
                continue
            _, cores, cstats, _ = cv2.connectedComponentsWithStats(core, connectivity=8)
            big = np.flatnonzero(cstats[:, cv2.CC_STAT_AREA] >= _least(r, radii[0]))
            big = big[big > 0]
            if len(big) >= 2:
                return t, cores, big, r
    return top, cores, big, r


def level_top_waists(
    mask: np.ndarray, height: np.ndarray, config: SegmentationConfig
) -> np.ndarray:
    """Pixels to cut where the tops of two touching objects meet level.

    Args:
        mask: (H, W) bool object pixels not yet cut (candidates less steps and creases).
        height: (H, W) height above the table, metres.
        config: ``level_top_px``, the radius (pixels) of the erosion that parts two tops at
            their waist (0 = off).

    Returns:
        (H, W) bool pixels to cut (none where no part holds two level tops).
    """
    import cv2

    out = np.zeros(mask.shape, bool)
    if config.level_top_px <= 0 or not mask.any():
        return out
    # The smallest disc that parts the top: two lids meet in a waist 8-15 px wide, a lid
    # against a box top or two lids nearer the camera in a wider one.
    radii = [round(config.level_top_px * f) for f in _RADII]
    _, lab, stats, _ = cv2.connectedComponentsWithStats(mask.astype(np.uint8), connectivity=4)
    for k in np.flatnonzero(stats[:, cv2.CC_STAT_AREA] >= 2 * _MIN_TOP_PX):
        if k == 0:
            continue
        x, y, w, h = stats[k, :4]
        sl = (slice(y, y + h), slice(x, x + w))
        part, hgt = lab[sl] == k, height[sl]
        top = part & (hgt > np.percentile(hgt[part], 98) - _TOP_BAND)
        if top.sum() < 2 * _MIN_TOP_PX:
            continue
        # Eroded within the top's own box (a pixel wider: the speck count sees the same
        # neighbours), a fraction of the part's box where walls stand below the top.
        rows, cols = np.flatnonzero(top.any(axis=1)), np.flatnonzero(top.any(axis=0))
        box = (
            slice(max(rows[0] - 1, 0), rows[-1] + 2),
            slice(max(cols[0] - 1, 0), cols[-1] + 2),
        )
        parted, cores, big, r = _cores(top[box], radii)
        if len(big) < 2:
            continue
        # Each top pixel's nearest core, within the box too: the cores and the parted top lie
        # in it, and a chamfer distance between two of its pixels never leaves it.
        dist = [cv2.distanceTransform((cores != c).astype(np.uint8), cv2.DIST_L2, 3) for c in big]
        nearest = np.where(parted, np.argmin(np.stack(dist), axis=0), -1)
        edge = np.zeros_like(part)
        inner = edge[box]  # (a view: the cut is marked in the part's box)
        for a, b, e in (
            (nearest[:, 1:], nearest[:, :-1], inner[:, 1:]),
            (nearest[1:], nearest[:-1], inner[1:]),
        ):
            e |= (a != b) & (a >= 0) & (b >= 0)
        cut = part & (cv2.dilate(edge.astype(np.uint8), _disk(_CUT_PX)) > 0)
        # Each piece the cut leaves around a core must stand on the table, unless they meet in
        # a waist (the one behind may be hidden below its top).
        _, pieces = cv2.connectedComponents((part & ~cut).astype(np.uint8), connectivity=4)
        owners = {int(np.bincount(pieces[box][cores == c]).argmax()) for c in big} - {0}
        if len(owners) < 2:
            continue
        waist = edge.sum() <= _WAIST_RADII * r
        if not waist and any(np.percentile(hgt[pieces == p], 5) > _STANDS for p in owners):
            continue
        out[sl] |= cut
    return out
