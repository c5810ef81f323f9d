"""One partial observation of one object: points, image-space mask and depth, camera, table."""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from typing import Any, Literal

import numpy as np

from symjax._pytree import pytree_dataclass
from symjax.array_types import ArrayLike
from symjax.camera import Camera
from symjax.errors import (
    CameraError,
    ConfigError,
    DegenerateGeometryError,
    EmptyInputError,
    InvalidInputError,
    ShapeError,
)
from symjax.geometry import cloud_bucket
from symjax.table import TablePlane
from symjax.validation import check_fields

__all__ = ["MIN_POINTS", "Observation", "SceneLimits", "stack_observations"]

#: Fewest valid points an observation may hold; below this no plane fit or symmetry is meaningful.
MIN_POINTS = 10

MaskFill = Literal["none", "close", "hull"]

#: Radius (pixels) of the closing of a mask filled with ``"close"`` unless told otherwise.
CLOSE_PX = 2


def clean_points(points: ArrayLike, what: str = "point cloud") -> np.ndarray:
    """Validates a cloud and drops non-finite rows.

    Args:
        points: Array-like of shape (N, 3), metres.
        what: Name used in error messages.

    Returns:
        float64 array (M, 3) of the finite rows.

    Raises:
        ShapeError: If the shape is not (N, 3).
        EmptyInputError: If fewer than :data:`MIN_POINTS` finite points remain.
    """
    p = np.asarray(points, dtype=np.float64)
    if p.ndim != 2 or p.shape[1] != 3:
        raise ShapeError(f"{what} must have shape (N, 3), got {p.shape}")
    if p.shape[0] == 0:
        raise EmptyInputError(f"{what} is empty; expected at least {MIN_POINTS} points")
    # One pass over the flat array first: most clouds are finite, and the per-row test (a
    # reduction over an axis of 3) is several times slower.
    if not np.isfinite(p).all():
        finite = np.all(np.isfinite(p), axis=1)
        if not finite.any():
            raise EmptyInputError(f"{what} has no finite points (all {p.shape[0]} are NaN or inf)")
        p = p[finite]
    if p.shape[0] < MIN_POINTS:
        raise EmptyInputError(
            f"{what} has {p.shape[0]} finite points; expected at least {MIN_POINTS}"
        )
    return p


@dataclasses.dataclass(frozen=True)
class SceneLimits:
    """What a table-top object and its camera can be; outside these a unit mistake is likely.

    Attributes:
        min_extent: Smallest object size (largest side of its bounding box), metres. Below it
            the points coincide or are in a larger unit (kilometres, or metres read as mm).
        max_extent: Largest object size, metres. Above it the points are likely millimetres.
        max_distance: Farthest object point from the camera, metres.
    """

    min_extent: float = 0.005
    max_extent: float = 2.0
    max_distance: float = 10.0

    def __post_init__(self) -> None:
        check_fields(self)
        if not 0 < self.min_extent < self.max_extent:
            raise ConfigError(
                f"SceneLimits needs 0 < min_extent < max_extent, got {self.min_extent},"
                f" {self.max_extent}"
            )
        if not self.max_distance > 0:
            raise ConfigError(f"max_distance must be > 0 m, got {self.max_distance}")

    def check(self, points: np.ndarray, camera: Camera, what: str = "the object") -> None:
        """Raises when ``points`` (M, 3) or their camera distance are outside the limits.

        Raises:
            InvalidInputError: Too large or too far (likely millimetres passed as metres).
            DegenerateGeometryError: Too small: the points coincide, or the unit is wrong.
        """
        # Per coordinate as contiguous rows: reductions over an (N, 3) array's short axis or
        # its strided columns are several times slower (a segmented 720p frame checks 7 objects).
        rows = np.ascontiguousarray(points.T)
        extent = float(np.max(rows.max(axis=1) - rows.min(axis=1)))
        if extent > self.max_extent:
            raise InvalidInputError(
                f"{what} is {extent:.4g} m across; a table-top object is at most"
                f" {self.max_extent} m (SceneLimits.max_extent): are the points in millimetres?"
                " symjax works in metres"
            )
        if extent < self.min_extent:
            raise DegenerateGeometryError(
                f"{what} is {extent * 1e3:.4g} mm across; expected at least"
                f" {self.min_extent * 1e3:g} mm (SceneLimits.min_extent): the points coincide or"
                " are in a larger unit than metres"
            )
        d = rows - np.asarray(camera.position, np.float64)[:, None]
        far = math.sqrt(float(np.max(d[0] * d[0] + d[1] * d[1] + d[2] * d[2])))
        if far > self.max_distance:
            raise InvalidInputError(
                f"{what} is {far:.4g} m from the camera; expected at most {self.max_distance} m"
                " (SceneLimits.max_distance): are the points or the camera pose in millimetres?"
            )


def render_points(points: np.ndarray, camera: Camera) -> tuple[np.ndarray, np.ndarray]:
    """Z-buffers points into a depth image and a hit mask.

    Args:
        points: World points (N, 3), metres, all in front of the camera.
        camera: The camera.

    Returns:
        ``(mask, depth)``: bool (H, W) and float32 (H, W) metres, 0 where no point projects.
    """
    uv, z = camera.project(points)
    uv, z = np.asarray(uv), np.asarray(z)
    col = np.rint(uv[:, 0]).astype(np.int64)
    row = np.rint(uv[:, 1]).astype(np.int64)
    inside = (col >= 0) & (col < camera.width) & (row >= 0) & (row < camera.height)
    flat = row[inside] * camera.width + col[inside]
    depth = np.full(camera.width * camera.height, np.inf)
    np.minimum.at(depth, flat, z[inside])
    depth[~np.isfinite(depth)] = 0.0
    depth = depth.reshape(camera.height, camera.width).astype(np.float32)
    return depth > 0, depth


def fill_mask(mask: np.ndarray, fill: MaskFill, close_px: int = CLOSE_PX) -> np.ndarray:
    """Fills gaps of a sparse projected mask.

    ``"hull"`` is the reference code's fill by the convex hull of the projection; ``"close"`` is a
    morphological closing of radius ``close_px`` (holes of stereo data without filling concavities);
    ``"none"`` keeps the mask as is.
    """
    import cv2

    if fill == "none":
        return mask
    m = mask.astype(np.uint8)
    if fill == "hull":
        pts = cv2.findNonZero(m)
        if pts is None:
            return mask
        out = np.zeros_like(m)
        cv2.fillConvexPoly(out, cv2.convexHull(pts), 1)
        return out.astype(bool) | mask
    if fill == "close":
        k = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * close_px + 1, 2 * close_px + 1))
        # Pad so that the closing does not erode at the image border.
        pad = close_px + 1
        mp = cv2.copyMakeBorder(m, pad, pad, pad, pad, cv2.BORDER_CONSTANT, value=0)
        mp = cv2.morphologyEx(mp, cv2.MORPH_CLOSE, k)
        return mp[pad:-pad, pad:-pad].astype(bool) | mask
    raise InvalidInputError(f"unknown mask fill {fill!r}; expected 'none', 'close' or 'hull'")


@pytree_dataclass
class Observation:
    """A partial view of one object, ready for the symmetry search.

    Attributes:
        points: Object points, shape (N, 3), metres, world frame; padded rows are zero.
        valid: Validity of each row, shape (N,), bool (padding lets views of different sizes
            batch together).
        table: The supporting plane.
        camera: The camera that took the view.
        mask: Binary segmentation mask of the object, shape (H, W), bool.
        depth: Depth image of the object, shape (H, W), metres along the optical axis; 0 = none.
            Outside the mask, a depth > 0 marks a surface in front of the object that hides it
            (an occluder, set by :func:`symjax.perception.segment`): the symmetry search takes
            those pixels as where the object may be hidden, not as empty space.
    """

    points: Any
    valid: Any
    table: TablePlane
    camera: Camera
    mask: Any
    depth: Any

    @classmethod
    def create(
        cls,
        points: ArrayLike,
        camera: Camera,
        table: TablePlane,
        mask: ArrayLike,
        depth: ArrayLike,
        valid: Any = None,
        limits: SceneLimits | None = None,
    ) -> Observation:
        """Builds a validated observation from given mask and depth images.

        ``limits`` (default :class:`SceneLimits`) bounds the object's size and distance.

        Raises:
            ShapeError: If shapes disagree (points not (N, 3), mask/depth not (H, W) of the camera).
            EmptyInputError: If there are fewer than 10 finite points or the mask is empty.
            CameraError: If points lie behind the camera.
        """
        if not isinstance(camera, Camera):
            raise InvalidInputError(f"camera must be a symjax.Camera, got {type(camera).__name__}")
        if not isinstance(table, TablePlane):
            raise InvalidInputError(
                f"table must be a symjax.TablePlane, got {type(table).__name__}"
            )
        p = np.asarray(points, dtype=np.float64)
        if valid is not None:
            valid = np.asarray(valid, dtype=bool)
            if p.ndim != 2 or valid.shape != (p.shape[0],):
                raise ShapeError(f"valid must have shape ({len(p)},), got {valid.shape}")
            p = p[valid]
        p = clean_points(p)
        (SceneLimits() if limits is None else limits).check(p, camera)
        _check_in_front(p, camera)
        mask = np.asarray(mask)
        depth = np.asarray(depth, dtype=np.float32)
        hw = (camera.height, camera.width)
        if mask.shape != hw:
            raise ShapeError(f"mask must have the camera's image shape {hw}, got {mask.shape}")
        if depth.shape != hw:
            raise ShapeError(f"depth must have the camera's image shape {hw}, got {depth.shape}")
        if not np.all(np.isfinite(depth)) or np.any(depth < 0):
            raise InvalidInputError("depth image must be finite and >= 0 (0 = no depth)")
        if not mask.any():
            raise EmptyInputError("segmentation mask is empty; the object must cover a pixel")
        return cls(
            points=p.astype(np.float32),
            valid=np.ones(len(p), dtype=bool),
            table=table,
            camera=camera,
            mask=mask.astype(bool),
            depth=depth,
        )

    @classmethod
    def from_points(
        cls,
        points: ArrayLike,
        camera: Camera,
        table: TablePlane,
        fill: MaskFill = "close",
        close_px: int = CLOSE_PX,
        limits: SceneLimits | None = None,
    ) -> Observation:
        """Builds an observation whose mask and depth image come from projecting the points.

        Args:
            points: Object points (N, 3), metres, world frame. Non-finite rows are dropped.
            camera: The camera that saw them.
            table: The supporting plane.
            fill: How to fill gaps of the projected mask: ``"close"`` (default, morphological
                closing of radius ``close_px`` pixels), ``"hull"`` (the reference code's convex hull
                of the projection) or ``"none"``.
            close_px: Closing radius in pixels for ``fill="close"``.
            limits: Bounds of the object's size and distance (default :class:`SceneLimits`).

        Raises:
            EmptyInputError: Fewer than 10 finite points, or none projects into the image.
            CameraError: Points behind the camera.
            InvalidInputError, DegenerateGeometryError: Outside ``limits`` (a unit mistake).
        """
        if not isinstance(camera, Camera):
            raise InvalidInputError(
                f"camera must be a symjax.Camera (e.g. Camera.create(K, T_world_cam, width,"
                f" height)), got {type(camera).__name__}"
            )
        p = clean_points(points)
        (SceneLimits() if limits is None else limits).check(p, camera)
        _check_in_front(p, camera)
        mask, depth = render_points(p, camera)
        if not mask.any():
            raise EmptyInputError(
                f"none of the {len(p)} points projects into the "
                f"{camera.width}x{camera.height} image"
            )
        mask = fill_mask(mask, fill, close_px)
        return cls.create(p, camera, table, mask, depth, limits=limits)

    @property
    def n_valid(self) -> int:
        """Number of valid points."""
        return int(np.asarray(self.valid).sum())

    def valid_points(self) -> np.ndarray:
        """The valid points as a numpy array (M, 3)."""
        return np.asarray(self.points)[np.asarray(self.valid)]

    def padded(self, n: int) -> Observation:
        """A copy with points padded (or already sized) to ``n`` rows."""
        p = np.asarray(self.points)
        v = np.asarray(self.valid)
        if len(p) > n:
            raise InvalidInputError(f"cannot pad {len(p)} points down to {n}")
        pad = n - len(p)
        return Observation(
            points=np.concatenate([p, np.zeros((pad, 3), p.dtype)]),
            valid=np.concatenate([v, np.zeros(pad, bool)]),
            table=self.table,
            camera=self.camera,
            mask=self.mask,
            depth=self.depth,
        )

    def transformed(self, T_new_world: ArrayLike) -> Observation:
        """The same observation after a rigid motion (4, 4) of the world frame.

        Images are unchanged.
        """
        T = np.asarray(T_new_world, dtype=np.float64)
        p = np.asarray(self.points, dtype=np.float64) @ T[:3, :3].T + T[:3, 3]
        p[~np.asarray(self.valid)] = 0.0
        return Observation(
            points=p.astype(np.float32),
            valid=self.valid,
            table=self.table.transformed(T),
            camera=self.camera.transformed(T),
            mask=self.mask,
            depth=self.depth,
        )


def _check_in_front(points: np.ndarray, camera: Camera) -> None:
    z = np.asarray(camera.world_to_camera(points))[:, 2]
    behind = int(np.sum(z <= 1e-6))
    if behind:
        raise CameraError(
            f"{behind} of {len(points)} points are behind the camera (depth <= 0); "
            "expected every object point in front of the camera (check the pose T_world_cam)"
        )


def stack_observations(observations: Sequence[Observation], n_points: int | None = None):
    """Stacks views into one batched :class:`Observation` (leading axis = view).

    Points are padded to a common bucketed size (:func:`symjax.geometry.cloud_bucket`, or
    ``n_points``) and images to the largest height and width (padding is outside the mask with
    no depth).

    Returns:
        A batched Observation whose camera's ``width``/``height`` are the padded image size.
    """
    if len(observations) == 0:
        raise EmptyInputError("no observations to stack")
    for i, o in enumerate(observations):
        if not isinstance(o, Observation):
            raise InvalidInputError(f"item {i} is a {type(o).__name__}, expected an Observation")
        if np.ndim(o.points) != 2:
            raise ShapeError(f"item {i} is already batched (points {np.shape(o.points)})")
    n = n_points or cloud_bucket(max(len(np.asarray(o.points)) for o in observations))
    H = max(o.camera.height for o in observations)
    W = max(o.camera.width for o in observations)
    padded = [o.padded(n) for o in observations]

    def pad_img(a, fillv):
        a = np.asarray(a)
        out = np.full((H, W), fillv, dtype=a.dtype)
        out[: a.shape[0], : a.shape[1]] = a
        return out

    cams = [o.camera for o in padded]
    return Observation(
        points=np.stack([np.asarray(o.points, np.float32) for o in padded]),
        valid=np.stack([np.asarray(o.valid) for o in padded]),
        table=TablePlane(
            normal=np.stack([np.asarray(o.table.normal) for o in padded]),
            offset=np.stack([np.asarray(o.table.offset) for o in padded]),
        ),
        camera=Camera(
            K=np.stack([np.asarray(c.K) for c in cams]),
            T_world_cam=np.stack([np.asarray(c.T_world_cam) for c in cams]),
            width=W,
            height=H,
        ),
        mask=np.stack([pad_img(o.mask, False) for o in padded]),
        depth=np.stack([pad_img(o.depth, 0.0) for o in padded]),
    )
