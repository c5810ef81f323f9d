"""Pixels that parts meeting on one surface trade across a round part's wall go back: objects on
a table do not overlap.

Where two objects meet without a crease (two bottles' shoulders at one height, a box face seen
at a grazing angle against a can), the crease cut may hand a strip of one to the other. A can's
or a bottle's wall stands on a circle of the table: its visible points lie on that circle and
its top, shoulder and neck inside it. So a point whose footprint lies inside a round neighbour's
disc belongs to that neighbour, and a point of a round part that stands outside its own circle
belongs to an adjacent part whose footprint holds it (or stays, as a mug's handle does).

A wall seen from one side is a short arc, and the circle through a short noisy arc is uncertain
in radius. The algebraic fit errs small there and the geometric fit large, so each move takes
the circle that errs against it: into a disc within the smaller, out of a part beyond the larger.

A bottle's neck marks its axis, however little of its wall is seen: the circle about the centre
of its top, as wide as its wall stands from there (:func:`neck_circle`), is its body's within a
few millimetres where a free fit through a short arc was centimetres off. A box whose top meets
a bottle's shoulder at one height (no crease, no depth step) takes the shoulder's ring and the
wall below it; what a neighbour holds within that circle, in one piece with what lies inside it,
goes back to the bottle, across a depth step too. The few pixels of a neighbour's face where it
touches the wall (within the circle's error of it, reaching nowhere inside) stay. A bottle's own
points stand within a centimetre of that circle; a piece well beyond it is a neighbour's face
seen on the other side of the bottle, which the crease band grew from the bottle through the
contact: it goes to the part it touches that comes nearest, within the bottle's width.
"""

from __future__ import annotations

import numpy as np

from symjax.perception.config import SegmentationConfig
from symjax.perception.footprint import (
    _MAX_ARC_RADIUS,
    fit_circle,
    hull_distance,
    robust_extent,
)
from symjax.perception.hull import convex_hull_2d
from symjax.perception.support import _MIN_TOUCH, _by_size, contacts, part_pixels

__all__ = ["neck_circle", "settle_round_parts", "wall_circles"]

_WALL = 0.6  # the wall: points below this share of the part's top height (not neck or shoulder)
_SAMPLE = 500  # wall points a circle is fitted to, at most
_MIN_PIXELS = 100  # smaller parts have no wall to speak of
_SPAN = 0.45  # a wall circle's radius is at least this share of its points' span (0.5 less noise)
# A part with more than this share of its pixels beyond its (larger) circle is not round as a
# whole: the circle is a box face's or two objects' (logged on the 270 examined scenes: parts
# that gave back their neighbours' pixels had at most 0.157 beyond, those that gave away their
# own 0.174 or more; 0.1 to 0.3 gave the same results).
_BEYOND = 0.16


# A neck: the part's top (points above _NECK_TOP of its top height) is at most _NECK_WIDTH of its
# wall's radius across (a bottle's neck is 0.8 of it, a can's lid and a box's top 2 or more), and
# the wall stands within _NECK_SPREAD (median, m) of the circle about the top's centre. Logged on
# the 136 bottles of 60 held-out scenes (true masks): centre 3.1 mm from the axis (median; 4.1 at
# the 90th percentile), radius 2.4 mm small (the top's points lean towards the camera).
_NECK_TOP = 0.97
_NECK_WIDTH = 1.0
_NECK_SPREAD = 0.002
# m: pixels within the neck circle plus this (its radius errs small by about as much) may go back
# to the bottle, in pieces (4-connected) of which _NECK_CORE lie within the circle itself.
_NECK_SLACK = 0.002
_NECK_CORE = 10
# m: a bottle's own points stand at most 8.7 mm beyond its neck's circle (the 66 bottles of the
# 50 benchmark scenes); what stands farther is a neighbour's (fresh scene 42: a box's face 2-6 cm
# beyond, seen on the other side of the bottle).
_NECK_BEYOND = 0.015

Circle = tuple[np.ndarray, float]  # (centre (2,), radius), metres


def wall_circles(
    foot: np.ndarray, height: np.ndarray, residual: float, margin: float
) -> tuple[Circle, Circle] | None:
    """The circle a round part's wall stands on, fitted two ways, or None when its wall is not
    round.

    Args:
        foot: (N, 2) the part's points on the table (a basis of the table plane), metres.
        height: (N,) their heights above the table, metres.
        residual: Largest median distance (m) of the wall's points from the circle: a box's
            two visible faces fit a circle several millimetres worse than a can's wall.
        margin: Metres: points farther than this (or twice the median) from the circle are
            left out of the refits (pixels the part took from a neighbour).

    Returns:
        ``(algebraic, geometric)``, each ``(centre (2,), radius)`` in metres. The algebraic
        (Kasa's) fit decides whether the wall is round. On a short arc it errs small; the
        geometric fit (the points' distances to the circle, refined from it) errs large. On the
        499 single cans and bottles of the 270 examined clutter scenes that met a neighbour:
        radius within 3 mm of the truth 85 % and 95 %.
    """
    if len(foot) < _MIN_PIXELS:
        return None
    step = max(1, len(foot) // (2 * _SAMPLE))  # the wall is at least half of a round part
    foot, height = foot[::step], height[::step]
    wall = foot[height < _WALL * np.percentile(height, 98)]
    wall = wall[:: max(1, len(wall) // _SAMPLE)]
    if len(wall) < 30:
        return None
    circle = fit_circle(wall)
    # An arc, not a straight face: a flat wall fits any circle much wider than itself.
    if circle is None or circle[1] > _MAX_ARC_RADIUS * float(np.max(np.ptp(wall, axis=0))):
        return None
    for _ in range(2):  # refits without the points that stray from the circle
        if circle is None:
            return None
        off = np.abs(_distance(wall, circle[0]) - circle[1])
        keep = wall[off <= max(margin, 2.0 * float(np.median(off)))]
        circle = fit_circle(keep) if len(keep) >= 10 else None
    if circle is None:
        return None
    off = np.abs(_distance(wall, circle[0]) - circle[1])
    if float(np.median(off)) > residual:
        return None
    # The points on a wall's circle span at most its diameter: a circle a few millimetres wide
    # through a cluster of them (fitted to a can 6 cm wide) is no wall's.
    on = wall[off <= max(margin, 2.0 * float(np.median(off)))]
    if len(on) < 10 or circle[1] < _SPAN * float(np.max(robust_extent(on))):
        return None
    return circle, _geometric_circle(np.asarray(on, np.float64), circle)


def neck_circle(foot: np.ndarray, height: np.ndarray) -> Circle | None:
    """The circle a bottle's wall stands on, about the axis its neck marks, or None when the
    part has no neck (its top is not narrow) or its wall is not round about the top's centre.

    Args:
        foot: (N, 2) the part's points on the table (a basis of the table plane), metres.
        height: (N,) their heights above the table, metres.

    Returns:
        ``(centre (2,), radius)``, metres: the centre of the top's points and the median
        distance of the wall's points (below :data:`_WALL` of the top height) from it.
    """
    if len(foot) < _MIN_PIXELS:
        return None
    step = max(1, len(foot) // (4 * _SAMPLE))
    foot, height = foot[::step], height[::step]
    top = np.percentile(height, 98)
    tip = foot[height > _NECK_TOP * top]
    wall = foot[height < _WALL * top]
    if len(tip) < 10 or len(wall) < 30:
        return None
    centre = tip.mean(axis=0)
    d = _distance(wall, centre)
    radius = float(np.median(d))
    if float(np.median(np.abs(d - radius))) > _NECK_SPREAD:
        return None
    if float(np.max(robust_extent(tip))) > _NECK_WIDTH * radius:
        return None
    return centre, radius


def _reaching_in(shape, pixels: np.ndarray, within: np.ndarray, inside: np.ndarray) -> np.ndarray:
    """Which of a part's ``pixels`` (flat indices into an image of ``shape``) that lie
    ``within`` a circle's slack are in one 4-connected piece with at least :data:`_NECK_CORE`
    pixels ``inside`` the circle itself: (N,) bool."""
    if not within.any():
        return within
    of = np.full(len(pixels), -1)
    of[within] = _pieces(shape, pixels[within])
    cores = np.bincount(of[within & inside], minlength=of.max() + 1) >= _NECK_CORE
    return within & np.append(cores, False)[of]  # (-1, not within: the appended False)


def _pieces(shape, pixels: np.ndarray) -> np.ndarray:
    """The 4-connected piece (0..P-1) of each of ``pixels`` (flat indices into an image of
    ``shape``, labelled on their bounding box only): (N,) int."""
    from scipy.ndimage import label

    r, c = np.divmod(pixels, shape[1])
    r0, c0 = r.min(), c.min()
    img = np.zeros((r.max() - r0 + 1, c.max() - c0 + 1), bool)
    img[r - r0, c - c0] = True
    return label(img)[0][r - r0, c - c0] - 1


def _geometric_circle(points: np.ndarray, start: Circle) -> Circle:
    """The circle (centre (2,), radius) nearest to points (N, 2) in the sum of squared
    distances, by Levenberg-Marquardt from a start circle, metres."""
    from scipy.optimize import least_squares

    def off(p):
        return _distance(points, p[:2]) - p[2]

    def jac(p):
        d = np.maximum(_distance(points, p[:2]), 1e-12)
        return np.column_stack([(p[0] - points[:, 0]) / d, (p[1] - points[:, 1]) / d,
                                -np.ones(len(points))])  # fmt: skip

    fit = least_squares(off, np.r_[start[0], start[1]], jac=jac, method="lm")
    return fit.x[:2], abs(float(fit.x[2]))


def _distance(points: np.ndarray, centre: np.ndarray) -> np.ndarray:
    """Distances (N,) of points (N, 2) from a centre (2,), metres."""
    return np.hypot(points[:, 0] - centre[0], points[:, 1] - centre[1])


def settle_round_parts(
    labels: np.ndarray,
    foot: np.ndarray,
    height: np.ndarray,
    depth: np.ndarray,
    config: SegmentationConfig,
    smooth: np.ndarray | None = None,
    touch: np.ndarray | None = None,
) -> np.ndarray:
    """Moves the pixels that parts meeting on one surface traded across round walls, and what
    any part took of a bottle within its neck's circle (module docstring).

    Args:
        labels: (H, W) int32 parts, -1 none.
        foot: (H, W, 2) the pixels' points on the table (:func:`footprint.table_footprint`, used
            where ``labels >= 0``), metres.
        height: (H, W) height above the table, metres.
        depth: (H, W) depth, metres (which parts meet on one surface, which only touch).
        config: ``round_margin`` (m, > 0), ``round_residual``, ``depth_jump``.
        smooth: (K, K) the parts' pixel pairs on one surface (:func:`support.contacts`'s first
            matrix, as :func:`support.join_supported` returns it); counted here when None.
        touch: (K, K) all their pixel pairs, across depth steps too (the second matrix);
            counted here when None and a part has a neck.

    Returns:
        (H, W) int32 labels, renumbered by decreasing size.
    """
    n = int(labels.max(initial=-1)) + 1
    if n < 2:
        return labels
    margin = config.round_margin
    # Only parts that meet on one surface (no depth step between them) trade pixels unseen:
    # across a step the far side is cut and goes back to its own surface already.
    if smooth is None:
        smooth, touch, _ = contacts(labels, depth, 0.5 * config.depth_jump, height)
    meet = smooth >= _MIN_TOUCH  # (no part meets itself: the diagonal is 0)
    F, Z = foot.reshape(-1, 2), height.ravel()
    order, starts, count = part_pixels(labels, n)
    pixels = [order[starts[k] : starts[k + 1]] for k in range(n)]
    feet, heights = [F[i] for i in pixels], [Z[i] for i in pixels]  # each part's, gathered once
    necks = {k: c for k in range(n) if (c := neck_circle(feet[k], heights[k])) is not None}
    # A neck's circle takes back from the parts it touches across a depth step too.
    near = meet
    if necks:
        if touch is None:
            touch = contacts(labels, depth, 0.5 * config.depth_jump, height)[1]
        near = meet | (touch >= _MIN_TOUCH)
        np.fill_diagonal(near, False)
    idx = {k: pixels[k] for k in range(n) if near[k].any()}
    fits = {k: wall_circles(feet[k], heights[k], config.round_residual, margin) for k in idx}
    # Each move by the circle that errs against it (module docstring).
    small = {k: None if f is None else f[0] for k, f in fits.items()}
    large = {k: None if f is None else f[1] for k, f in fits.items()}
    # New owner of each part's pixels (its own label where it keeps them).
    owner = {k: np.full(len(i), k) for k, i in idx.items()}
    # Into a round part's disc: what a neighbour holds well inside it (but never most of the
    # neighbour, nor what lies within the neighbour's own circle). Into a neck's circle: what a
    # neighbour holds within it, in pieces that reach inside it (module docstring).
    for b in idx:
        neck = necks.get(b)
        cb = neck if neck is not None else small[b]
        if cb is None:
            continue
        reach = cb[1] + _NECK_SLACK if neck is not None else cb[1] - margin
        for a in np.flatnonzero((meet if neck is None else near)[b]):
            dist = _distance(feet[a], cb[0])
            deep = dist < reach
            ca = large[a]
            if ca is not None:
                deep &= _distance(feet[a], ca[0]) > ca[1] - margin
            if neck is not None:
                deep = _reaching_in(labels.shape, idx[a], deep, dist < cb[1])
            if deep.sum() < 0.5 * len(deep):
                owner[a][deep] = b
    # Out of a round part: what stands beyond its circle, to the adjacent part nearest to
    # holding it (within the margin of its circle or footprint hull). What it took from its
    # neighbours above lies inside its disc.
    hulls: dict = {}

    def hull(b):  # a part's footprint hull, once (on at most about 4,000 of its points)
        if b not in hulls:
            hulls[b] = convex_hull_2d(feet[b][:: max(1, len(feet[b]) // 4000)])
        return hulls[b]

    for a, ca in large.items():
        if ca is None:
            continue
        far = np.flatnonzero((owner[a] == a) & (_distance(feet[a], ca[0]) > ca[1] + margin))
        if not len(far) or len(far) > _BEYOND * len(feet[a]):
            continue
        f = feet[a][far]
        best, gap = np.full(len(far), -1), np.full(len(far), np.inf)
        for b in np.flatnonzero(meet[a]):
            cb = small[b]
            if cb is not None:
                g = _distance(f, cb[0]) - cb[1]
            else:
                g = -hull_distance(hull(b), f)
            take = (g <= margin) & (g < gap)
            best[take], gap[take] = b, g[take]
        owner[a][far[best >= 0]] = best[best >= 0]
    # Out of a bottle: what stands well beyond its neck's circle is a neighbour's, seen on the
    # other side of it (the bottle hides the gap); it goes to the part it touches, across a depth
    # step too, whose footprint hull is nearest, within the bottle's width.
    for a, ca in necks.items():
        if a not in idx:
            continue
        beyond = _distance(feet[a], ca[0]) > ca[1] + _NECK_BEYOND
        far = np.flatnonzero((owner[a] == a) & beyond)
        if not len(far) or len(far) > _BEYOND * len(feet[a]):
            continue
        f = feet[a][far]
        piece = _pieces(labels.shape, idx[a][far])  # (whole pieces: none split at the bound)
        best, gap = np.full(piece.max() + 1, -1), np.full(piece.max() + 1, np.inf)
        for b in np.flatnonzero(near[a]):
            g = np.full(len(gap), np.inf)
            np.minimum.at(g, piece, -hull_distance(hull(b), f))
            take = (g <= 2 * ca[1]) & (g < gap)
            best[take], gap[take] = b, g[take]
        owner[a][far] = np.where(best[piece] >= 0, best[piece], a)
    out = labels.copy()
    flat = out.reshape(-1)
    moved = False
    for k, o in owner.items():
        gone = o != k
        if gone.any():
            moved = True
            flat[idx[k][gone]] = o[gone]
            # Renumbered by size from the counts, not a recount of the image.
            count[k] -= gone.sum()
            count += np.bincount(o[gone], minlength=n)
    return _by_size(count)[out] if moved else labels  # (_by_size maps -1 to -1)
