"""A round object and what it took in one part: a can that touches a box face, split apart.

A can or a bottle that touches a box face tangentially meets it without a depth step and without
a crease: the surfaces are continuous, only their curvature changes. The crease cut then leaves
both in one part, or gives the round object a strip of its neighbour. On the table the two stay
apart: the round object's wall stands on a circle, and what lies beyond that circle is not its.

A part's wall (its points below :data:`_WALL` of its top height) is searched for a circle by
RANSAC on its footprint (three points a circle, the circle with most points within
:data:`_TOLERANCE`). The circle is a round object's wall when its points cover a contiguous arc
(at least :data:`_ARC`, no gap over :data:`_HOLE`) and most of the wall inside it lies on it
(:data:`_PURITY`): a rounded box or an irregular object (a scanned mug, a pitcher) has wall
inside any circle that is not on it. The largest connected piece beyond the circle (by
:data:`_GAP`) becomes a part of its own; the joins that follow (:mod:`support`,
:mod:`occluded_halves`) give a strip back to the object it belongs to.

A wall with a wider gap (up to :data:`_WIDE_HOLE`: an occluder's strip in front of it) counts
when the part has next to no wall by the circle inside the gap (:data:`_GAP_FILL`: two faces
of a small box that a circle grazes leave their corner there), and gives up only a piece that
stands beside it (:data:`_PIECE_WALL` of it wall): a flat piece is then a sliver of a
neighbour's top, which the joins may not give back when its own part does not reach that far.
"""

from __future__ import annotations

import numpy as np

from symjax.perception.support import relabel_by_size

__all__ = ["split_round_objects"]

_WALL = 0.7  # the wall: points below this share of the part's top height (not a bottle's neck)
_TOLERANCE = 0.0015  # m: a point lies on a circle within this
_RADII = (0.015, 0.06)  # m: the radii of round objects' walls
_TRIES = 400  # circles drawn per part (a fixed seed: the same labels every run)
_SAMPLE = 600  # wall points the circles are scored on, at most
_ON_PIXELS = 150  # pixels on the circle, at least
_ARC = 75.0  # deg: the wall's points cover at least this arc ...
_HOLE = 15.0  # ... with no gap inside it over this, ...
_WIDE_HOLE = 30.0  # ... or over this, when the gap is empty and the piece beyond walled:
_GAP_FILL = 0.15  # wall pixels in the gap within _GAP of the circle, per pixel on it, at most
_PIECE_WALL = 0.1  # share of the piece's pixels that are wall, at least
_PURITY = 0.6  # share of the wall inside the circle's ring that lies on the circle, at least
_GAP = 0.006  # m: beyond the circle by this, a pixel is not the round object's
_REST = 0.03  # the piece beyond: at least this share of the part (and min_cluster_points)


def _circles(points: np.ndarray, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """Circles through random triples of points (N, 2): centres (C, 2) and radii (C,) within
    :data:`_RADII` (collinear triples dropped)."""
    a, b, c = (points[i] for i in rng.integers(0, len(points), (_TRIES, 3)).T)
    det = 2.0 * (a[:, 0] * (b[:, 1] - c[:, 1]) + b[:, 0] * (c[:, 1] - a[:, 1])
                 + c[:, 0] * (a[:, 1] - b[:, 1]))  # fmt: skip
    ok = np.abs(det) > 1e-12
    det = np.where(ok, det, 1.0)
    sa, sb, sc = (a * a).sum(1), (b * b).sum(1), (c * c).sum(1)
    x = (sa * (b[:, 1] - c[:, 1]) + sb * (c[:, 1] - a[:, 1]) + sc * (a[:, 1] - b[:, 1])) / det
    y = (sa * (c[:, 0] - b[:, 0]) + sb * (a[:, 0] - c[:, 0]) + sc * (b[:, 0] - a[:, 0])) / det
    centre = np.stack([x, y], axis=1)
    r = np.linalg.norm(a - centre, axis=1)
    ok &= (r >= _RADII[0]) & (r <= _RADII[1])
    return centre[ok], r[ok]


def _arc(angles: np.ndarray) -> tuple[float, float, float]:
    """Degrees of the arc that angles (N,) in radians cover (the circle less its largest gap),
    the largest gap inside that arc, and the angle where that gap starts (radians)."""
    s = np.sort(angles)
    gaps = np.degrees(np.diff(np.concatenate([s, s[:1] + 2.0 * np.pi])))
    if len(gaps) < 2:
        return 360.0 - float(gaps[0]), 0.0, float(s[0])
    order = np.argsort(gaps)
    return 360.0 - float(gaps[order[-1]]), float(gaps[order[-2]]), float(s[order[-2]])


def _beyond_wall(foot: np.ndarray, height: np.ndarray, rng) -> tuple | None:
    """Which of a part's pixels (footprints (N, 2), heights (N,)) lie beyond a round object's
    wall circle (N,) bool, which are wall (N,) bool and whether the circle's arc has a gap over
    :data:`_HOLE`; None when its wall has no such circle."""
    wall = height < _WALL * np.percentile(height, 98)
    points = foot[wall]
    if len(points) < 50:
        return None
    sample = points[:: max(1, len(points) // _SAMPLE)]
    centre, r = _circles(sample, rng)
    if len(r) == 0:
        return None
    # On the circle: (r - tol)^2 < d^2 < (r + tol)^2, without the square roots of |p - c|.
    s32, c32 = sample.astype(np.float32), centre.astype(np.float32)
    dx = s32[None, :, 0] - c32[:, :1]
    dy = s32[None, :, 1] - c32[:, 1:]
    d2 = dx * dx
    d2 += dy * dy
    lo, hi = (((r + e) ** 2)[:, None].astype(np.float32) for e in (-_TOLERANCE, _TOLERANCE))
    best = int(np.argmax(((d2 > lo) & (d2 < hi)).sum(axis=1)))
    centre, r = centre[best], r[best]
    dist = np.linalg.norm(foot - centre, axis=1)
    on = wall & (np.abs(dist - r) < _TOLERANCE)
    beyond = dist > r + _GAP
    if on.sum() < _ON_PIXELS or on.sum() < _PURITY * (wall & ~beyond).sum():
        return None
    angle = np.arctan2(foot[:, 1] - centre[1], foot[:, 0] - centre[0])
    arc, hole, start = _arc(angle[on])
    if arc < _ARC or hole > _WIDE_HOLE:
        return None
    if hole > _HOLE:
        # A round wall's gap is where something in front hides it: the part has no wall there
        # by the circle. Two box faces that a circle grazes leave their corner in the gap.
        in_gap = np.mod(angle - start, 2.0 * np.pi) < np.radians(hole)
        if (in_gap & wall & ~on & ~beyond).sum() > _GAP_FILL * on.sum():
            return None
    return beyond, wall, hole > _HOLE


def split_round_objects(
    labels: np.ndarray, foot: np.ndarray, height: np.ndarray, min_pixels: int
) -> np.ndarray:
    """Splits off what lies beyond a round object's wall in each part (module docstring).

    Args:
        labels: (H, W) int32 parts, -1 none.
        foot: (H, W, 2) the pixels' points on the table (:func:`footprint.table_footprint`),
            metres.
        height: (H, W) height above the table, metres.
        min_pixels: The fewest pixels of a piece split off (``min_cluster_points``).

    Returns:
        (H, W) int32 labels, renumbered by decreasing size (``labels`` itself when nothing is
        split).
    """
    import cv2
    from scipy.ndimage import find_objects

    n = int(labels.max(initial=-1)) + 1
    out, new = labels.copy(), n
    rng = np.random.default_rng(0)
    for k, box in enumerate(find_objects(labels + 1, max_label=n)):
        if box is None:
            continue
        rr, cc = np.nonzero(labels[box] == k)  # in the part's box
        if len(rr) < 2 * min_pixels:
            continue
        found = _beyond_wall(foot[box][rr, cc].astype(np.float64), height[box][rr, cc], rng)
        if found is None:
            continue
        beyond, wall, wide = found
        least = max(min_pixels, _REST * len(rr))
        if beyond.sum() < least:
            continue
        piece = np.zeros(labels[box].shape, np.uint8)
        piece[rr[beyond], cc[beyond]] = 1
        ids = cv2.connectedComponents(piece, connectivity=4)[1][rr, cc]
        sizes = np.bincount(ids[beyond])
        sizes[0] = 0
        largest = int(np.argmax(sizes))
        walled = not wide or wall[ids == largest].mean() >= _PIECE_WALL
        if sizes[largest] >= least and walled:
            out[box][rr[ids == largest], cc[ids == largest]] = new
            new += 1
    return labels if new == n else relabel_by_size(out)
