"""The reference loop of the part-contact tests: every 4-neighbour pixel pair of two parts."""

from __future__ import annotations

import numpy as np


def pixel_pairs(labels: np.ndarray):
    """Yields ``(a, b, p, q)``: labels ``a != b`` (both >= 0) of the pixels ``p`` and ``q`` (row,
    column), ``q`` right of or below ``p``, one pixel at a time."""
    H, W = labels.shape
    for r in range(H):
        for c in range(W):
            for r2, c2 in ((r, c + 1), (r + 1, c)):
                if r2 >= H or c2 >= W:
                    continue
                a, b = labels[r, c], labels[r2, c2]
                if a >= 0 and b >= 0 and a != b:
                    yield a, b, (r, c), (r2, c2)
