"""One view packed for the symmetry kernels: points, camera and the mask/depth image."""

from __future__ import annotations

from typing import Any

import numpy as np

from symjax._pytree import pytree_dataclass
from symjax.errors import DegenerateGeometryError, InvalidInputError, ShapeError
from symjax.observation import MIN_POINTS, Observation

__all__ = ["OCCLUDER_OFFSET", "ViewArrays", "prepare_view"]

#: Byte alignment at which XLA:CPU takes a numpy array without copying it (measured: a
#: 1280 x 960 float32 image passes in 0.03 ms aligned, 0.43 ms copied; a tenth of the paper's
#: search on a 40,000-point view).
ALIGNMENT = 64
#: Added to an occluder's depth in :attr:`ViewArrays.image` (metres): the kernel tells the
#: occluder's pixels from the object's own by it (a mirrored point behind an occluder is hidden,
#: neither inside nor outside the mask for Eq. 3). Depths stay below it; float32 keeps an
#: occluder's depth to 0.06 mm there, against a 2 mm depth tolerance.
OCCLUDER_OFFSET = 1000.0


@pytree_dataclass
class ViewArrays:
    """Arrays of one view (or a batch, with a leading axis) as the kernel reads them; numpy on
    the host (the jitted kernel moves them), so that stacking views compiles nothing.

    Attributes:
        points: (N, 3) world points, metres; padded rows are ignored.
        valid: (N,) bool.
        table_normal: (3,) unit up normal of the table.
        R_wc: (3, 3) camera-to-world rotation.
        t_wc: (3,) camera centre, metres.
        K: (3, 3) intrinsics, pixels.
        image: (H, W) per pixel, where the object may be seen: on its mask the observed depth,
            metres (0 = no measurement), on the occluders in front of it their depth plus
            :data:`OCCLUDER_OFFSET` metres; elsewhere minus the distance to those pixels, pixels
            (>= 1). One channel, so that one 4-byte gather serves both terms of Eq. 3 (the depth
            only matters where the distance is 0).
        occluded: () bool: whether any pixel is an occluder's.
    """

    points: Any
    valid: Any
    table_normal: Any
    R_wc: Any
    t_wc: Any
    K: Any
    image: Any
    occluded: Any


# ---------------------------------------------------------------------------------------------
# Host-side preparation


def aligned_empty(shape, dtype) -> np.ndarray:
    """An uninitialised array whose data starts at a multiple of :data:`ALIGNMENT` bytes."""
    dtype = np.dtype(dtype)
    nbytes = int(np.prod(shape, dtype=np.int64)) * dtype.itemsize
    buf = np.empty(nbytes + ALIGNMENT, np.uint8)
    start = (-buf.ctypes.data) % ALIGNMENT
    return buf[start : start + nbytes].view(dtype).reshape(shape)


def aligned(x, dtype) -> np.ndarray:
    """``np.asarray(x, dtype)`` copied to an :data:`ALIGNMENT`-byte boundary."""
    x = np.asarray(x)
    out = aligned_empty(x.shape, dtype)
    out[...] = x
    return out


def aligned_stack(arrays) -> np.ndarray:
    """``np.stack(arrays)`` into an aligned array (a batch of views passes without a copy)."""
    first = np.asarray(arrays[0])
    out = aligned_empty((len(arrays),) + first.shape, first.dtype)
    return np.stack(arrays, out=out)


def mask_distance(mask: np.ndarray, depth: np.ndarray) -> np.ndarray:
    """Distance (pixels, exact Euclidean) from every pixel to where the object may be seen.

    That is its mask and the pixels of the objects in front of it (depth > 0 outside the mask,
    see :func:`symjax.perception.segment`): a mirrored point behind an occluder is hidden, not
    contradicted, and is judged by the occluder's depth instead (Eq. 3's in-front test).
    """
    import cv2

    seen = np.asarray(mask, bool) | (np.asarray(depth) > 0)
    return cv2.distanceTransform((~seen).astype(np.uint8), cv2.DIST_L2, cv2.DIST_MASK_PRECISE)


def prepare_view(obs: Observation, n_points: int | None = None) -> ViewArrays:
    """Packs one observation for the kernel: distance transform and depth in one image.

    Args:
        obs: A single (unbatched) observation.
        n_points: Pad the points to this many rows (default: no padding).

    Raises:
        ShapeError: If ``obs`` is batched or its images disagree with its camera.
    """

    if not isinstance(obs, Observation):
        raise InvalidInputError(f"expected a symjax.Observation, got {type(obs).__name__}")
    if np.ndim(obs.points) != 2:
        raise ShapeError(
            f"expected one view (points (N, 3)), got points {np.shape(obs.points)}; "
            "use search_batch for several views"
        )
    mask = np.asarray(obs.mask, bool)
    depth = np.asarray(obs.depth, np.float32)
    if mask.shape != depth.shape:
        raise ShapeError(f"mask {mask.shape} and depth {depth.shape} images must match")
    if not mask.any():
        raise InvalidInputError("segmentation mask is empty")
    valid = np.asarray(obs.valid, bool)
    n_valid = int(valid.sum())
    if n_valid < MIN_POINTS:
        raise InvalidInputError(f"observation has {n_valid} valid points; need >= {MIN_POINTS}")
    pts = np.asarray(obs.points, np.float64)[valid]
    bad = int(np.sum(~np.all(np.isfinite(pts), axis=1)))
    if bad:
        raise InvalidInputError(
            f"{bad} of the {n_valid} valid points are NaN or inf; expected finite points (build"
            " the view with Observation.create, which drops them)"
        )
    # The search needs a spread on the table: a vertical line or coinciding points give no axis.
    n = np.asarray(obs.table.normal, np.float64)
    flat = pts - np.outer(pts @ n, n)
    spread = float(np.max(np.ptp(flat, axis=0)))
    if spread < 1e-4:
        raise DegenerateGeometryError(
            f"the valid points span {spread * 1e3:.3g} mm on the table; expected an object at"
            " least 0.1 mm wide (coinciding points, or points on one vertical line)"
        )
    if n_points is not None:
        obs = obs.padded(n_points)
    deepest = float(depth.max()) if depth.size else 0.0
    if deepest >= OCCLUDER_OFFSET:
        raise InvalidInputError(
            f"depth image reaches {deepest:.4g} m; expected depths below {OCCLUDER_OFFSET:g} m"
            " (a table-top view)"
        )
    dt = mask_distance(mask, depth)
    occluder = ~mask & (depth > 0)
    occluded = bool(occluder.any())
    seen = depth
    if occluded:  # (most views have none: no copy of the image then)
        seen = depth.copy()
        np.add(seen, np.float32(OCCLUDER_OFFSET), out=seen, where=occluder)
    T = np.asarray(obs.camera.T_world_cam, np.float64)
    return ViewArrays(
        points=aligned(obs.points, np.float32),
        valid=aligned(obs.valid, bool),
        table_normal=np.asarray(obs.table.normal, np.float32),
        R_wc=T[:3, :3].astype(np.float32),
        t_wc=T[:3, 3].astype(np.float32),
        K=np.asarray(obs.camera.K, np.float32),
        image=aligned(np.where(dt > 0, -dt, seen), np.float32),
        occluded=np.asarray(occluded),
    )
