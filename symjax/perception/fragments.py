"""Fragments: pieces of surface that the crease cut leaves too small to be objects, kept as parts
until the joins have said whose they are.

The crease cut (:func:`symjax.perception.creases.crease_mask`) leaves bands of cut pixels around
the contacts of touching objects, and sometimes a small piece of surface inside such a band: a
strip of a bottle seen in the gap between two nearer cans, with fewer than
``min_cluster_points`` seed pixels. Left unlabelled, the piece and its band were reattached
pixel by pixel to whatever object the band reached by the smallest depth steps first, which can
be the box that the bottle touches: the contact line is continuous in depth, and from there the
strip grew into the box although it stands 2-4 cm in front of the box face (fresh clutter scene
10,279: 300 pixels of the bottle in the box's mask, the box's symmetry plane 14 mm off).

Labelled in the reattachment (:func:`fragment_labels`), a fragment takes its own share of the
band by depth continuity, and then stays a part like the others through the joins that use the
footprints on the table (:mod:`symjax.perception.support`,
:mod:`symjax.perception.occluded_halves`, :mod:`symjax.perception.round_parts`): the strip of
scene 10,279 is joined to a piece of its bottle seen on the other side of a nearer can (the two
halves of one object), and that to the rest of the bottle by support. A part made of fragments
alone after the joins is no object and is dropped (:func:`drop_fragments`), as the small
component was before. Joining fragments by depth alone, to the adjacent object they continue
with the smallest step, was tried first and gave pieces to touching neighbours (held-out and
fresh clutter scenes; README, "Fragments, measured").
"""

from __future__ import annotations

import numpy as np

__all__ = ["drop_fragments", "fragment_labels"]


def fragment_labels(
    components: np.ndarray, remap: np.ndarray, size: np.ndarray, n_objects: int, min_px: int
) -> np.ndarray:
    """The labels of the objects and, after them, of the fragments.

    Args:
        components: (H, W) int32 connected components of the uncut pixels (0 = none).
        remap: (N,) int32 each component's object label, -1 for those that are no object.
        size: (N,) pixels of each component.
        n_objects: Objects (labels 0..n_objects-1).
        min_px: Fewest pixels of a fragment.

    Returns:
        int32 (H, W): objects 0..n_objects-1, fragments n_objects.., -1 elsewhere.
    """
    remap = remap.copy()
    frag = np.flatnonzero((remap < 0) & (size >= min_px))
    frag = frag[frag > 0]
    remap[frag] = n_objects + np.arange(len(frag), dtype=np.int32)
    return remap[components]


def drop_fragments(labels: np.ndarray, fragment: np.ndarray) -> np.ndarray:
    """The parts made of fragments' pixels alone, unlabelled.

    Args:
        labels: (H, W) int32 parts, -1 elsewhere.
        fragment: (H, W) bool pixels that were fragments' before the joins.

    Returns:
        int32 (H, W) labels; a part keeps its label when any of its pixels was an object's.
    """
    n = int(labels.max()) + 1
    if n <= 0:
        return labels
    held = np.bincount(labels[~fragment & (labels >= 0)], minlength=n) > 0
    return np.where((labels >= 0) & ~held[np.maximum(labels, 0)], -1, labels).astype(np.int32)
