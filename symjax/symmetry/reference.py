"""Plain numpy reference of the visibility vote (Eq. 3), one hypothesis at a time.

Written independently of the JAX kernel, as the paper describes it, to check the kernel's numbers
and to time the speed-up of the vectorised search.
"""

from __future__ import annotations

import numpy as np

from symjax.observation import Observation
from symjax.symmetry.config import SymmetryConfig

__all__ = ["score_planes_numpy"]


def score_planes_numpy(
    obs: Observation, normals: np.ndarray, offsets: np.ndarray, config: SymmetryConfig
) -> tuple[np.ndarray, np.ndarray]:
    """Scores planes ``{x : n . x = d}`` of one view with a Python loop over hypotheses.

    Args:
        obs: One observation.
        normals: (P, 3) unit plane normals.
        offsets: (P,) plane offsets, metres.
        config: Weights, tolerance and normalisation of the vote.

    Returns:
        ``(outside, inside)``: (P,) ``E[delta_1]`` (pixels^2) and ``E[delta_2]`` (metres).
    """
    import cv2

    P = obs.valid_points().astype(np.float64)
    mask = np.asarray(obs.mask, bool)
    depth = np.asarray(obs.depth, np.float64)
    H, W = mask.shape
    seen = mask | (depth > 0)  # objects in front of it keep their depth outside its mask
    dt = cv2.distanceTransform((~seen).astype(np.uint8), cv2.DIST_L2, cv2.DIST_MASK_PRECISE)
    T = np.asarray(obs.camera.T_world_cam, np.float64)
    K = np.asarray(obs.camera.K, np.float64)
    outside = np.zeros(len(normals))
    inside = np.zeros(len(normals))
    for h, (nrm, off) in enumerate(zip(np.asarray(normals), np.asarray(offsets), strict=True)):
        q = P - 2.0 * np.outer(P @ nrm - off, nrm)
        xc = (q - T[:3, 3]) @ T[:3, :3]
        x, y, z = xc.T
        front = z > 1e-6
        zs = np.where(front, z, 1.0)
        col = np.round((K[0, 0] * x + K[0, 1] * y) / zs + K[0, 2])
        row = np.round(K[1, 1] * y / zs + K[1, 2])
        cc, rr = np.clip(col, 0, W - 1), np.clip(row, 0, H - 1)
        dist = dt[rr.astype(int), cc.astype(int)] + np.hypot(col - cc, row - rr)
        is_in = front & (dist <= 0)
        is_out = ~is_in
        c = config.outside_huber_px
        loss = dist**2 if c <= 0 else np.where(dist <= c, dist**2, c * (2.0 * dist - c))
        d1 = np.where(front, loss, float(H * H + W * W))
        observed = depth[rr.astype(int), cc.astype(int)]
        ahead = is_in & (observed > 0) & (z < observed - config.depth_tolerance)
        # Behind an occluder (depth outside the mask) a mirrored point is hidden: in neither
        # subset.
        hidden = is_in & ~mask[rr.astype(int), cc.astype(int)] & ~ahead
        d1_sum, n_out = float(d1[is_out].sum()), int(is_out.sum())
        d2_sum, n_in = float((observed - z)[ahead].sum()), int((is_in & ~hidden).sum())
        if config.normalize == "subset":
            outside[h] = d1_sum / max(n_out, 1)
            inside[h] = d2_sum / max(n_in, 1)
        else:
            outside[h] = d1_sum / max(len(P), 1)
            inside[h] = d2_sum / max(len(P), 1)
    return outside, inside
