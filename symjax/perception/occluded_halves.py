"""The two halves of one object that a nearer object cuts apart, joined.

A box behind a bottle's neck shows its face on either side of the neck; nothing joins the two
pieces in the image, so the crease cut finds two objects. Two halves of one object do not touch
each other (or meet along a few pixels without a depth step, above a nearer part that ends lower;
along a few dozen where neither half is round, a box's face above a neck), both lie behind one
nearer part along their boundaries, and reach the same top height (the object's lid or rim, seen
on both sides); where either half stands on an arc of the table (a round wall), both stand on one
arc of about its radius; and together they are no wider than one object.
Distinct objects behind one occluder rarely meet all of these: their tops differ, they touch each
other or one lies in front of the other, their arcs are two, or together they are wider than any
object (two bottles of one height behind a can stand 20 cm apart).

The halves are joined as the creases cut them, before the parts that stand on others join
(:func:`symjax.perception.support.join_supported`): a hidden bottle's shoulder would join one strip
of its body, and that part's top would then be the shoulder's, not the body's.
"""

from __future__ import annotations

import numpy as np

from symjax.perception.config import SegmentationConfig
from symjax.perception.footprint import principal_extents, round_footprint
from symjax.perception.support import _MIN_TOUCH, _by_size, neighbour_pairs, part_pixels

__all__ = ["join_occluded_halves", "occluders"]

#: Metres: the largest difference of the two halves' top heights (95th percentile of each).
_SAME_TOP = 0.001
#: Where a half is round, the circle through both halves has at most this multiple of its radius.
#: Logged on the 270 examined scenes: 1.1-1.33 for the halves of one bottle; 3.5 for the body
#: strips of two bottles either side of a nearer one (scene 221), whose footprints fit a wide
#: circle loosely enough to pass as one arc.
_ONE_ARC = 2.0
#: Pixel pairs: two halves may meet along this many at most, without a depth step, where the
#: nearer part leaves a gap (a neck lower than the object behind it) that a crease cut across.
#: Logged on the 270 examined scenes: 4-15 for halves of one object, none across a step; the
#: pieces of two objects that pass the other tests met across a step (10-60 pairs).
_MEET = 20
#: Pixel pairs: two halves neither of which stands on an arc (a box's face either side of a
#: bottle's neck, meeting above it where the neck ends lower) may meet along this many at most.
#: On the 270 examined and the second sample: 23-46 for the box halves the 20 left apart (scenes
#: 50 and 215 of the sample); a limit from 80 to 120 mends the same scenes and breaks none, while
#: round halves meeting along 24 pairs were two bottles' (scene 17 of the 270).
_MEET_FLAT = 100


def occluders(labels: np.ndarray, depth: np.ndarray, step: float) -> tuple[np.ndarray, np.ndarray]:
    """Which parts lie in front of which, from their 4-neighbour pixel pairs.

    Args:
        labels: (H, W) int parts, -1 none.
        depth: (H, W) metres.
        step: Metres: a pair whose depths differ by more is an occluding edge.

    Returns:
        ``(nearer, touch)``, each (K, K): ``nearer[i, j]`` the pairs where part i lies nearer
        than part j by more than ``step``; ``touch`` all pairs of the two parts (symmetric).
    """
    n = int(labels.max(initial=-1)) + 1
    a, b, (za, zb) = neighbour_pairs(labels, depth)
    touch = np.bincount(a * n + b, minlength=n * n).reshape(n, n)
    nearer = np.bincount((a * n + b)[za < zb - step], minlength=n * n)
    nearer += np.bincount((b * n + a)[zb < za - step], minlength=n * n)
    return nearer.reshape(n, n), touch + touch.T


def join_occluded_halves(
    labels: np.ndarray,
    foot: np.ndarray,
    height: np.ndarray,
    depth: np.ndarray,
    config: SegmentationConfig,
) -> np.ndarray:
    """Joins pairs of parts that one nearer part separates (see the module docstring).

    Args:
        labels: (H, W) int32 parts, -1 none.
        foot: (H, W, 2) the pixels' points in a basis of the table plane, metres, where
            ``labels >= 0`` (:func:`symjax.perception.footprint.table_footprint`).
        height: (H, W) height above the table, metres.
        depth: (H, W) metres.
        config: ``halves_extent`` (the widest two halves may be together, m; 0 = off) and
            ``depth_jump`` (the step by which the occluder lies nearer).

    Returns:
        (H, W) int32 labels renumbered by decreasing size; ``labels`` itself where nothing
        joins.
    """
    n = int(labels.max(initial=-1)) + 1
    if n < 3 or config.halves_extent <= 0:
        return labels
    nearer, touch = occluders(labels, depth, config.depth_jump)
    front = nearer >= _MIN_TOUCH  # [c, a]: c lies in front of a along a boundary
    order, starts, count = part_pixels(labels, n)
    hgt, flat = height.ravel(), foot.reshape(-1, 2)
    idx = [order[starts[k] : starts[k + 1]] for k in range(n)]
    top = np.array([np.percentile(hgt[i], 95) if len(i) else np.nan for i in idx])
    owner = np.arange(n)
    for a in range(n):
        for b in range(a + 1, n):
            # The cheap tests first: most pairs differ in height or touch.
            if touch[a, b] > _MEET_FLAT or nearer[a, b] or nearer[b, a]:
                continue
            if not abs(top[a] - top[b]) <= _SAME_TOP:
                continue
            if not np.any(front[:, a] & front[:, b]):
                continue
            fa, fb = flat[idx[a]], flat[idx[b]]
            both = np.concatenate([fa, fb])
            if principal_extents(both)[0] > config.halves_extent:
                continue
            arcs = [c for c in (round_footprint(fa), round_footprint(fb)) if c is not None]
            if arcs:
                if touch[a, b] > _MEET:
                    continue
                one = round_footprint(both)
                if one is None or one[1] > _ONE_ARC * min(r for _, r in arcs):
                    continue
            owner[owner == owner[b]] = owner[a]
    if (owner == np.arange(n)).all():
        return labels
    rank = _by_size(np.bincount(owner, weights=count, minlength=n).astype(np.int64))
    return np.append(rank[owner], np.int32(-1))[labels]
