"""Parts cut off one object by a crease are joined back: a bottle's neck on its shoulder, a band
of an object's side that a crease runs across.

The crease cut cannot tell a neck on a shoulder from a small object standing on a box: both meet
their support in a concave edge. Objects on a table stand on the table, and two objects cannot
stand on the same piece of it, so a part is joined to an adjacent one when most of its footprint
lies on that part's footprint (the other part being lower, for a part whose lowest points float
above the table, or larger otherwise), or when it is too narrow to be an object of its own and
meets a part without a depth step (stacked objects therefore come out as one hypothesis) and,
standing on the table itself, does not rise well above it (the strip of a bottle behind a can is
narrow, but taller than the can); a part that floats above the table is too narrow when it was so
as the creases cut it, before the parts above it joined it, and then joins only a part it meets
from above whose footprint lies under its own (a bottle's shoulder with its neck, behind another
bottle, goes to the strip of its body below it, not to the box in front whose top it meets); a
round part (a neck) joins only a part whose footprint lies around its axis, by any of these rules
(not the neighbour a mostly hidden bottle's neck and shoulder meet level, nor the box their
footprint reaches into at its edge). A floating part that none of these joins goes to a part
that ends where it begins and stands under it (a hidden bottle's shoulder and the strip of its body
beside the object in front). An object partly hidden behind another is not joined: its footprint
lies behind the front one's.
"""

from __future__ import annotations

import numpy as np

from symjax.perception.config import SegmentationConfig
from symjax.perception.footprint import (
    hull_distance,
    principal_extents,
    robust_extent,
    round_footprint,
)
from symjax.perception.hull import convex_hull_2d

__all__ = [
    "contacts",
    "join_supported",
    "neighbour_pairs",
    "part_pixels",
    "relabel_by_size",
]

_FOOTPRINT_SLACK = 0.005  # m: a point may lie this far outside the support's footprint ...
#: ... and this share of the part's points must lie on it. 0.75, not 0.8: a hidden bottle's neck
#: reaches past the hull of the arc of shoulder seen beside its occluders (scene 14 of the 270
#: examined: 0.801 from depth, 0.76 with colour). Of the 49 hull tests on those scenes (depth and
#: colour) between 0.75 and 0.8, 44 paired parts of one object and none two objects' (5 had a
#: part whose middle pixel is on none); between 0.8 and 0.85, 2 of 43 paired two objects.
_ON_SUPPORT = 0.75
_RISE = 0.001  # m: mean height step across the contact of a shoulder on its body
_MIN_TOUCH = 5  # pixel pairs: parts touching less than this are not neighbours
# m: a narrow part standing on the table whose top is this much higher than a neighbour's is
# no piece of it (a bottle behind a can, seen as a strip beside it from the table up)
_TOWER = 0.02
# m: a round part (a neck) joins only a part whose footprint lies around its axis, 90 % of it
# within this distance plus the part's radius of its circle's centre (its bottle's body; a
# neighbour's lies farther; a bowl's wider rim reaches farther)
_AXIS_REACH = 0.06
# m: a floating part that joins no part by the rules above goes to a part it touches that ends
# where it begins (that part's top from 3 cm below its lowest points to 1 cm above) and stands
# under it (90 % of that part's footprint within 3 cm of its hull): a hidden bottle's shoulder
# and the strip of its body seen beside the object in front, whose noisy occluding edge leaves
# few pixel pairs without a depth step between them. Logged on the 270 examined scenes, such
# pairs of one object lay within 2.3 cm of the hull (90th percentile of the lower part's
# footprint; 507 pairs, 6 more with a lower part mixed of two objects) and those of two objects
# 4.3 cm or more away (307 pairs). A floating narrow part joins a part it meets from above only
# when that part stands under it so: a hidden bottle's shoulder and neck, seen above the box in
# front of it, meet the box's top from above too (5 of the 270 scenes of the second sample).
_BELOW = (0.03, 0.01)
_UNDER = 0.03


def relabel_by_size(labels: np.ndarray) -> np.ndarray:
    """Labels renumbered 0..K-1 by decreasing pixel count (-1 kept)."""
    n = int(labels.max(initial=-1)) + 1
    if n == 0:
        return labels
    return _by_size(np.bincount(labels[labels >= 0], minlength=n))[labels]


def _by_size(size: np.ndarray) -> np.ndarray:
    """Lookup table (K + 1,) from labels with ``size`` (K,) pixels to their rank by decreasing
    size (ties in label order), -1 for empty labels and at index -1 (unlabelled pixels)."""
    order = np.flatnonzero(size)[np.argsort(-size[np.flatnonzero(size)], kind="stable")]
    remap = np.full(len(size) + 1, -1, np.int32)
    remap[order] = np.arange(len(order), dtype=np.int32)
    return remap


def neighbour_pairs(labels: np.ndarray, *images: np.ndarray) -> tuple:
    """The 4-neighbour pixel pairs of two different parts.

    Args:
        labels: (H, W) int parts, -1 none.
        *images: (H, W) arrays whose values at the two pixels are wanted.

    Returns:
        ``(a, b, (ia, ib), ...)``: flat arrays over the pairs, ``a`` the left or upper pixel's
        part and ``b`` the other's (int64), and for each image its values at the two pixels.
    """
    rows = []  # per direction: a, b, then each image's values at the two pixels
    for first, second in (
        ((slice(None), slice(None, -1)), (slice(None), slice(1, None))),
        ((slice(None, -1), slice(None)), (slice(1, None), slice(None))),
    ):
        a, b = labels[first], labels[second]
        pair = (a != b) & (a >= 0) & (b >= 0)
        rows.append([a[pair], b[pair]])
        rows[-1] += [v for img in images for v in (img[first][pair], img[second][pair])]
    cols = [np.concatenate(c) for c in zip(*rows, strict=True)]
    return (*(c.astype(np.int64) for c in cols[:2]), *zip(cols[2::2], cols[3::2], strict=True))


def contacts(
    labels: np.ndarray, depth: np.ndarray, max_step: float, height: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Where parts meet, from their 4-neighbour pixel pairs.

    Args:
        labels: (H, W) int parts, -1 none.
        depth: (H, W) metres.
        max_step: Metres: pairs whose depths differ by less meet on one surface, not across an
            occluding edge.
        height: (H, W) height above the table, metres.

    Returns:
        ``(smooth, touch, rise)``, each (K, K): counts of the pairs of two parts on one surface
        and of all their pairs, and the sums over the smooth pairs of the first part's height
        minus the second's (antisymmetric: positive where the first meets the second from
        above).
    """
    n = int(labels.max(initial=-1)) + 1
    a, b, (za, zb), (ha, hb) = neighbour_pairs(labels, depth, height)
    ab = a * n + b
    on = np.abs(za - zb) < max_step
    touch = np.bincount(ab, minlength=n * n)
    smooth = np.bincount(ab[on], minlength=n * n)
    rise = np.bincount(ab[on], (ha - hb)[on].astype(np.float64), minlength=n * n)
    smooth, touch, rise = (x.reshape(n, n) for x in (smooth, touch, rise))
    return smooth + smooth.T, touch + touch.T, rise - rise.T


def _is_narrow(foot: np.ndarray, height: np.ndarray, narrow: float) -> bool:
    """Too small to be an object of its own: narrower than ``narrow`` (m) across, or a thin
    piece (under 0.6 of that thick) at most twice that long and high (a mug's handle)."""
    major, minor = principal_extents(foot)
    tall = float(robust_extent(height[:: max(1, len(foot) // 2000)]))
    return bool(major < narrow or (minor < 0.6 * narrow and max(major, tall) < 2 * narrow))


def _disc(foot: np.ndarray) -> tuple[np.ndarray, float] | None:
    """``(centre, radius)`` of the disc a round footprint covers, or None when not round: the
    arc's circle, reaching out to the outermost points (a bowl's inside covers the whole disc)."""
    circle = round_footprint(foot)
    if circle is None:
        return None
    sub = foot[:: max(1, len(foot) // 2000)]
    reach = float(np.percentile(np.linalg.norm(sub - circle[0], axis=1), 95))
    return circle[0], max(circle[1], reach)


def _within(inner: np.ndarray, disc) -> bool:
    """Most of the footprint ``inner`` lies within ``disc`` (see :func:`_disc`)."""
    if disc is None:
        return False
    d = np.linalg.norm(inner[:: max(1, len(inner) // 500)] - disc[0], axis=1)
    return bool(np.mean(d <= disc[1] + 2 * _FOOTPRINT_SLACK) >= _ON_SUPPORT)


def part_pixels(labels: np.ndarray, n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Each part's flat pixel indices, in increasing order: ``order[starts[k]:starts[k + 1]]``
    for part k of ``n``, with ``count`` (n,) pixels each (labels (H, W), -1 none)."""
    flat = labels.ravel()
    # A stable sort of the labelled pixels by label (of 16-bit keys, a radix sort: linear in
    # the pixels), not a scan of the image per part.
    sel = np.flatnonzero(flat >= 0)
    keys = flat[sel]
    order = sel[np.argsort(keys.astype(np.int16) if n < 2**15 else keys, kind="stable")]
    count = np.bincount(keys, minlength=n)
    return order, np.concatenate([[0], np.cumsum(count)]), count


def join_supported(
    labels: np.ndarray,
    foot: np.ndarray,
    height: np.ndarray,
    config: SegmentationConfig,
    depth: np.ndarray | None = None,
    with_contacts: bool = False,
) -> np.ndarray | tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Joins the parts of one object that creases cut apart (see the module docstring).

    Args:
        labels: (H, W) int32 parts, -1 none.
        foot: (H, W, 2) the pixels' points in a basis of the table plane, metres (used where
            ``labels >= 0``; :func:`table_footprint`).
        height: (H, W) height above the table, metres.
        config: ``support_height``, ``support_narrow``, ``depth_jump``.
        depth: (H, W) depth, metres: a narrow part joins only a part it meets without a depth
            step (under half ``depth_jump``); None = any part it touches.
        with_contacts: Also return the joined parts' pixel pairs on one surface and all their
            pixel pairs, the first two matrices of :func:`contacts` of the returned labels
            (kept up to date while joining, so that later steps need not count them again).

    Returns:
        (H, W) int32 labels, renumbered by decreasing size; with ``with_contacts`` also those
        two (K, K) matrices.
    """
    n = int(labels.max(initial=-1)) + 1
    if n < 2:
        none = np.zeros((n, n), np.int64)
        return (labels, none, none.copy()) if with_contacts else labels
    z = depth if depth is not None else np.zeros(labels.shape, np.float32)
    step = 0.5 * config.depth_jump if depth is not None else np.inf
    # contact: pixel pairs on one surface; touch: all pairs, across depth steps too; rise: how
    # far above the part it meets a part is there.
    contact, touch, rise = contacts(labels, z, step, height)
    order, starts, count = part_pixels(labels, n)
    foot_all = foot.reshape(-1, 2)
    hgt = height.ravel()
    # Per part: pixel indices, footprint (N, 2) and lowest height (5th percentile).
    parts = {}
    for k in range(n):
        idx = order[starts[k] : starts[k + 1]]
        if len(idx):
            parts[k] = [idx, foot_all[idx], float(np.percentile(hgt[idx], 5))]
    owner = np.arange(n)
    # Part -> its footprint's convex hull, and its round footprint's disc (or None), computed
    # when first needed.
    hulls: dict = {}
    discs: dict = {}
    tops: dict = {}  # part -> its top height (95th percentile), when first needed

    def top(k: int) -> float:
        if k not in tops:
            tops[k] = float(np.percentile(hgt[parts[k][0]], 95))
        return tops[k]

    def disc(k: int):
        if k not in discs:
            discs[k] = _disc(parts[k][1])
        return discs[k]

    def hull(k: int) -> np.ndarray:
        if k not in hulls:
            hulls[k] = convex_hull_2d(parts[k][1][:: max(1, len(parts[k][1]) // 4000)])
        return hulls[k]

    def around(k: int, foot: np.ndarray) -> bool:
        # The footprint (N, 2) lies around the axis of part k, if k is round (a neck).
        if disc(k) is None:
            return True
        f = foot[:: max(1, len(foot) // 500)]
        reach = float(np.percentile(np.linalg.norm(f - disc(k)[0], axis=1), 90))
        return reach <= _AXIS_REACH + disc(k)[1]

    def beneath(k: int, j: int) -> bool:
        # Part j's footprint lies under part k's.
        f = parts[j][1][:: max(1, len(parts[j][1]) // 500)]
        return bool(np.mean(hull_distance(hull(k), f) >= -_UNDER) >= 0.9)

    def under(k: int, j: int) -> bool:
        # Part j ends where part k begins and stands under k's footprint.
        return -_BELOW[0] <= top(j) - parts[k][2] <= _BELOW[1] and beneath(k, j)

    # Highest parts first, so that a chain (cap on neck on body) collapses downwards.
    for k in sorted(parts, key=lambda k: -parts[k][2]):
        idx, own, low = parts[k]
        narrow = _is_narrow(own, hgt[idx], config.support_narrow)
        on_top = False  # narrow only as cut: it may join only a part it meets from above
        if not narrow and low > config.support_height:
            # A floating part is judged as the creases cut it: a shoulder that took its neck
            # is still a shoulder, but it stands on its body, above it where they meet; the
            # hidden bottle's shoulder beside a box meets the box level. Parts that reach the
            # table are judged with what joined them: a can's bottom band that took the can.
            cut = order[starts[k] : starts[k + 1]]
            narrow = on_top = _is_narrow(foot_all[cut], hgt[cut], config.support_narrow)
        own = own[:: max(1, len(own) // 500)]
        best, nearest, below = None, None, None
        for j in np.argsort(-touch[k], kind="stable"):
            if touch[k, j] < _MIN_TOUCH:
                break
            if j == k or j not in parts:
                continue
            foot = parts[j][1]
            if not around(k, foot):  # a neck joins by no rule a part off its axis
                continue
            if below is None and low > config.support_height and under(k, j):
                below = j
            if (
                narrow
                and contact[k, j] > 0
                and (not on_top or (rise[k, j] > _RISE * contact[k, j] and beneath(k, j)))
                and not (low <= config.support_height and top(k) > top(j) + _TOWER)
            ):
                gap = float(np.median(np.linalg.norm(foot - own.mean(axis=0), axis=1)))
                if nearest is None or gap < nearest[1]:
                    nearest = (j, gap)
            # Floating parts may stand on a lower part; any part may lie within a larger one's
            # footprint (a band of an object's side cut off by a crease across it).
            if parts[j][2] >= low if low > config.support_height else len(foot) <= len(idx):
                continue
            if np.mean(hull_distance(hull(j), own) >= -_FOOTPRINT_SLACK) >= _ON_SUPPORT:
                best = j
                break
            # A round part's footprint is an arc: what lies within its circle is inside it (the
            # inside of a mug or a bowl behind the front of its wall, or the front of the wall
            # before the inside whose circle holds it).
            if _within(own, disc(j)) or _within(foot, disc(k)):
                best = j
                break
        # A narrow part without a part to stand on goes to the part it meets without a depth
        # step whose footprint is nearest to its own (the shoulder a neck stands on).
        best = best if best is not None or nearest is None else nearest[0]
        best = best if best is not None else below
        if best is not None:
            owner[owner == k] = best
            parts[best][0] = np.concatenate([parts[best][0], idx])
            parts[best][1] = np.concatenate([parts[best][1], parts[k][1]])
            discs.pop(best, None)
            tops.pop(best, None)
            hulls.pop(best, None)
            for mat in (contact, touch, rise):
                mat[best] += mat[k]
                mat[:, best] += mat[:, k]
                mat[k], mat[:, k] = 0, 0
            del parts[k]
    # Renumbered by the joined parts' sizes in one lookup (relabel_by_size of owner[labels]).
    rank = _by_size(np.bincount(owner, weights=count, minlength=n).astype(np.int64))
    joined = np.append(rank[owner], np.int32(-1))[labels]
    if not with_contacts:
        return joined
    alive = np.array(sorted(parts))
    out = []
    for mat in (contact, touch):
        pairs = np.zeros((len(alive), len(alive)), mat.dtype)
        pairs[np.ix_(rank[alive], rank[alive])] = mat[np.ix_(alive, alive)]
        np.fill_diagonal(pairs, 0)  # pairs inside a joined part are no contact
        out.append(pairs)
    return joined, *out
