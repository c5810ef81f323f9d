"""Touching objects joined through a few pixels, split: erosion finds the bridge, the cores
grow back over the pixels around them, and a split stands only across a step or a crease.

One pair of pixels on one surface across the contact of two touching objects (a gap in the
crease, a depth step under the jump) joins both into one connected component
(:func:`symjax.perception.clusters.image_clusters`). Eroded by a small disc such a component
falls apart into large cores, while one object's own parts do not (a bottle's neck is several
times wider than the bridge). Real stereo data nearly cut by noise creases falls apart too, but
there the parts continue each other without a step, and are joined back.
"""

from __future__ import annotations

import numpy as np

from symjax.perception.config import SegmentationConfig

__all__ = ["grow_cores", "rejoin_smooth", "thin_bridges"]


def thin_bridges(
    core: np.ndarray, height: np.ndarray, config: SegmentationConfig
) -> tuple[np.ndarray, np.ndarray]:
    """Where two objects' pixels join through a thin bridge: the pixels to cut, and the
    components they were cut from.

    One pair of pixels on one surface across the contact of two touching objects (a gap in the
    crease, a step under the jump) joins both into one component. Eroded by a disc of
    ``split_bridges_px``, such a component falls apart into two or more large cores, while an
    object's own parts do not (a bottle's neck is several times wider than the bridge). Only
    components with at least two cores of ``min_cluster_points`` seed pixels change: all their
    pixels but the cores are cut (see :func:`grow_cores`).

    Returns:
        ``(rim, component)``: (H, W) bool pixels cut, and (H, W) int32 the split component each
        pixel belongs to (0 = none).
    """
    import cv2

    rim = np.zeros_like(core)
    component = np.zeros(core.shape, np.int32)
    r = config.split_bridges_px
    disc = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * r + 1, 2 * r + 1))
    eroded = cv2.erode(core.astype(np.uint8), disc).astype(bool)
    m, sub = cv2.connectedComponents(eroded.astype(np.uint8), connectivity=4, ltype=cv2.CV_32S)
    seeds = np.bincount(sub[eroded & (height > config.seed_height)], minlength=m)
    seeds[0] = 0
    big = np.flatnonzero(seeds >= config.min_cluster_points)
    if len(big) < 2:
        return rim, component
    _, lab = cv2.connectedComponents(core.astype(np.uint8), connectivity=4, ltype=cv2.CV_32S)
    # Each core lies inside one component (erosion only removes pixels).
    parent = np.zeros(m, np.int64)
    parent[sub[eroded]] = lab[eroded]
    comps, counts = np.unique(parent[big], return_counts=True)
    split = np.isin(lab, comps[counts >= 2])
    if split.any():
        component = np.where(split, lab, 0).astype(np.int32)
        rim = split & ~np.isin(sub, big)
    return rim, component


def grow_cores(
    labels: np.ndarray, rim: np.ndarray, component: np.ndarray, blocked: np.ndarray | None
) -> np.ndarray:
    """The cut pixels of split components labelled from the cores they continue: labels grow
    a pixel a pass through the cut pixels of the same component, never across a ``blocked``
    pixel (a colour crease) nor into another object across a depth step or a crease (which the
    cut pixels' reattachment by depth would allow). Cut pixels no core reaches stay -1."""
    rows, cols = np.nonzero(rim)
    box = (slice(rows.min(), rows.max() + 1), slice(cols.min(), cols.max() + 1))
    grow = rim[box] if blocked is None else rim[box] & ~blocked[box]
    comp = component[box]
    # One pixel of frame: the labels beside the box may feed the pixels on its edge.
    lab = np.pad(labels, 1, constant_values=-1)
    cp = np.pad(component, 1)
    inner = (slice(box[0].start + 1, box[0].stop + 1), slice(box[1].start + 1, box[1].stop + 1))
    sub = lab[inner]  # a view: passes write through to lab
    while True:
        open_ = grow & (sub < 0)
        took = np.zeros_like(open_)
        for dr, dc in ((0, 1), (1, 0), (0, -1), (-1, 0)):
            nb = (slice(inner[0].start + dr, inner[0].stop + dr),
                  slice(inner[1].start + dc, inner[1].stop + dc))  # fmt: skip
            ok = open_ & ~took & (lab[nb] >= 0) & (cp[nb] == comp)
            sub[ok] = lab[nb][ok]
            took |= ok
        if not took.any():
            break
    return lab[1:-1, 1:-1]


#: The two halves of the horizontal and the vertical 4-neighbour pixel pairs.
_PAIRS = (
    ((slice(None), slice(None, -1)), (slice(None), slice(1, None))),
    ((slice(None, -1), slice(None)), (slice(1, None), slice(None))),
)
#: A split stands where the parts meet across a step or a crease: the median depth difference
#: of the pixel pairs across their boundary at least this (m; within one surface a stereo
#: head's neighbouring pixels differ by about 0.3 mm, KTH's real view) ...
_SPLIT_MIN_STEP = 0.0025
#: ... and, with creases, their median concavity at least this share of the crease threshold.
_SPLIT_MIN_CREASE = 1.5


def rejoin_smooth(
    labels: np.ndarray,
    component: np.ndarray,
    depth: np.ndarray,
    concavity: np.ndarray | None,
    config: SegmentationConfig,
    colour_crease: np.ndarray | None = None,
) -> np.ndarray:
    """Parts of one split component joined back where their boundary is one smooth surface:
    noise creases that nearly cut one object (real stereo data) leave thin bridges too, but
    the parts on either side of them continue each other without a step. Parts whose boundary
    follows a colour crease for the most part stay apart (objects that colour separates)."""
    from scipy.cluster.hierarchy import DisjointSet
    from scipy.ndimage import find_objects

    boxes = [(k, b) for k, b in enumerate(find_objects(component), start=1) if b is not None]
    if not boxes:
        return labels
    n = int(labels.max()) + 1
    joined = DisjointSet(range(n))

    for k, box in boxes:
        # The parts of the component's cores, and their boundary in a margin around it.
        parts = np.unique(labels[box][(component[box] == k) & (labels[box] >= 0)])
        if len(parts) < 2:
            continue
        r0, r1 = max(box[0].start - 2, 0), box[0].stop + 2
        c0, c1 = max(box[1].start - 2, 0), box[1].stop + 2
        lab, dep = labels[r0:r1, c0:c1], depth[r0:r1, c0:c1]
        kap = None if concavity is None else concavity[r0:r1, c0:c1]
        edge = None
        if colour_crease is not None:
            import cv2

            # A pixel pair on either side of a crease line, or on it.
            edge = cv2.dilate(colour_crease[r0:r1, c0:c1].astype(np.uint8), np.ones((3, 3)))
            edge = edge.astype(bool)
        a_all, b_all, dz_all, kz_all, ez_all = [], [], [], [], []
        for sa, sb in _PAIRS:
            a, b = lab[sa], lab[sb]
            sel = (a != b) & np.isin(a, parts) & np.isin(b, parts)
            a_all.append(np.minimum(a, b)[sel])
            b_all.append(np.maximum(a, b)[sel])
            dz_all.append(np.abs(dep[sa] - dep[sb])[sel])
            if kap is not None:
                kz_all.append(np.maximum(kap[sa], kap[sb])[sel])
            if edge is not None:
                ez_all.append((edge[sa] | edge[sb])[sel])
        a, b, dz = np.concatenate(a_all), np.concatenate(b_all), np.concatenate(dz_all)
        kz = np.concatenate(kz_all) if kap is not None else None
        ez = np.concatenate(ez_all) if edge is not None else None
        for pa, pb in {(int(x), int(y)) for x, y in zip(a, b, strict=True)}:
            on = (a == pa) & (b == pb)
            step = float(np.median(dz[on])) >= _SPLIT_MIN_STEP
            if kz is not None and config.crease_threshold is not None:
                step &= float(np.median(kz[on])) >= _SPLIT_MIN_CREASE * config.crease_threshold
            if ez is not None:
                step |= float(np.mean(ez[on])) >= 0.5
            if not step:
                joined.merge(pa, pb)
    if joined.n_subsets == n:
        return labels
    from symjax.perception.support import relabel_by_size

    top = np.array([joined[i] for i in range(n)])
    return relabel_by_size(np.where(labels >= 0, top[np.maximum(labels, 0)], -1).astype(np.int32))
