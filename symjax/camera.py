"""Pinhole camera model (OpenCV convention: x right, y down, z forward)."""

from __future__ import annotations

from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

from symjax._pytree import pytree_dataclass, static_field
from symjax.array_types import ArrayLike
from symjax.errors import CameraError, ShapeError
from symjax.geometry import pixel_rays

__all__ = ["Camera"]


@pytree_dataclass
class Camera:
    """A pinhole camera.

    Attributes:
        K: Intrinsics, shape (3, 3), pixels: ``[[fx, s, cx], [0, fy, cy], [0, 0, 1]]``.
        T_world_cam: Pose, shape (4, 4): maps camera coordinates (metres) to world coordinates.
        width: Image width in pixels (static).
        height: Image height in pixels (static).
    """

    K: Any
    T_world_cam: Any
    width: int = static_field()
    height: int = static_field()

    def __post_init__(self) -> None:
        # Static fields are concrete even under jit: a float or bool size is a caller's mistake.
        for name in ("width", "height"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, int | np.integer):
                raise CameraError(f"camera {name} must be a whole number of pixels, got {v!r}")

    @classmethod
    def create(cls, K: ArrayLike, T_world_cam: ArrayLike, width: int, height: int) -> Camera:
        """Builds a validated camera from array-likes (float64 numpy, converted lazily by JAX).

        Raises:
            CameraError: If K is not a valid intrinsic matrix, the pose is not rigid, or the
                image size is not positive.
        """
        K = np.asarray(K, dtype=np.float64)
        T = np.asarray(T_world_cam, dtype=np.float64)
        if K.shape != (3, 3):
            raise ShapeError(f"camera K must have shape (3, 3), got {K.shape}")
        if T.shape != (4, 4):
            raise ShapeError(f"camera T_world_cam must have shape (4, 4), got {T.shape}")
        if not (np.all(np.isfinite(K)) and np.all(np.isfinite(T))):
            raise CameraError("camera K and T_world_cam must be finite (found NaN or inf)")
        if K[0, 0] <= 0 or K[1, 1] <= 0:
            raise CameraError(f"camera focal lengths must be > 0, got fx={K[0, 0]}, fy={K[1, 1]}")
        if not np.allclose(K[2], [0.0, 0.0, 1.0]) or abs(K[1, 0]) > 1e-9:
            raise CameraError(f"camera K must be upper triangular with last row [0, 0, 1], got {K}")
        R = T[:3, :3]
        if not np.allclose(R @ R.T, np.eye(3), atol=1e-5) or np.linalg.det(R) < 0:
            raise CameraError("camera T_world_cam rotation must be orthonormal with det +1")
        if not np.allclose(T[3], [0.0, 0.0, 0.0, 1.0]):
            raise CameraError("camera T_world_cam last row must be [0, 0, 0, 1]")
        for name, v in (("width", width), ("height", height)):
            integral = isinstance(v, int | np.integer) or (
                isinstance(v, float | np.floating) and float(v).is_integer()
            )
            if isinstance(v, bool) or not integral:
                raise CameraError(f"camera {name} must be a whole number of pixels, got {v!r}")
        if int(width) <= 0 or int(height) <= 0:
            raise CameraError(f"image size must be positive, got {width}x{height}")
        return cls(K=K, T_world_cam=T, width=int(width), height=int(height))

    @classmethod
    def from_intrinsics(
        cls, fx: float, fy: float, cx: float, cy: float, width: int, height: int, T_world_cam=None
    ) -> Camera:
        """Builds a camera from focal lengths and principal point (pixels)."""
        K = np.array([[fx, 0.0, cx], [0.0, fy, cy], [0.0, 0.0, 1.0]])
        return cls.create(K, np.eye(4) if T_world_cam is None else T_world_cam, width, height)

    @classmethod
    def look_at(
        cls,
        position: ArrayLike,
        target: ArrayLike,
        K: ArrayLike,
        width: int,
        height: int,
        up: ArrayLike = (0.0, 0.0, 1.0),
    ) -> Camera:
        """A camera at ``position`` (m) whose optical axis points at ``target`` (m).

        The image's "up" (negative y) is the projection of ``up`` onto the image plane.

        Raises:
            CameraError: If position equals target or the view direction is parallel to ``up``.
        """
        p = np.asarray(position, dtype=np.float64).reshape(3)
        t = np.asarray(target, dtype=np.float64).reshape(3)
        u = np.asarray(up, dtype=np.float64).reshape(3)
        z = t - p
        if np.linalg.norm(z) < 1e-12:
            raise CameraError("look_at: position and target coincide")
        z /= np.linalg.norm(z)
        x = np.cross(z, u)
        if np.linalg.norm(x) < 1e-9:
            raise CameraError("look_at: viewing direction is parallel to the up vector")
        x /= np.linalg.norm(x)
        y = np.cross(z, x)
        T = np.eye(4)
        T[:3, :3] = np.stack([x, y, z], axis=1)
        T[:3, 3] = p
        return cls.create(K, T, width, height)

    # -- geometry (works on numpy or jax arrays; jnp so that it can run inside jit) --

    @property
    def position(self):
        """Camera centre in world coordinates, shape (3,), metres."""
        return self.T_world_cam[:3, 3]

    def world_to_camera(self, points: ArrayLike) -> jax.Array:
        """Points (..., 3) world -> camera coordinates (..., 3)."""
        R = self.T_world_cam[:3, :3]
        t = self.T_world_cam[:3, 3]
        return (points - t) @ R

    def project(self, points: ArrayLike) -> tuple[jax.Array, jax.Array]:
        """Projects world points to pixels.

        Args:
            points: World points, shape (..., 3), metres.

        Returns:
            ``(uv, depth)``: pixel coordinates (..., 2) (u = column, v = row, continuous, pixel
            centres at integers) and depth along the optical axis (...,), metres.
        """
        xc = self.world_to_camera(points)
        z = xc[..., 2]
        zs = jnp.where(jnp.abs(z) < 1e-12, 1e-12, z)
        K = self.K
        u = K[0, 0] * xc[..., 0] / zs + K[0, 1] * xc[..., 1] / zs + K[0, 2]
        v = K[1, 1] * xc[..., 1] / zs + K[1, 2]
        return jnp.stack([u, v], axis=-1), z

    def backproject(self, depth: ArrayLike) -> tuple[jax.Array, jax.Array]:
        """Back-projects a depth image to world points.

        Args:
            depth: Depth image, shape (height, width), metres along the optical axis; 0 = none.

        Returns:
            ``(points, valid)``: world points (height*width, 3) in row-major pixel order and a
            boolean mask (height*width,) of pixels with depth > 0.
        """
        depth = jnp.asarray(depth)
        if depth.shape != (self.height, self.width):
            raise ShapeError(
                f"depth image must have shape ({self.height}, {self.width}), got {depth.shape}"
            )
        z = depth.reshape(-1)
        rays = pixel_rays(jnp.asarray(self.K, depth.dtype), self.height, self.width, xp=jnp)
        xc = rays.reshape(-1, 3) * z[:, None]
        R = self.T_world_cam[:3, :3]
        t = self.T_world_cam[:3, 3]
        return xc @ R.T + t, z > 0

    def transformed(self, T_new_world: ArrayLike) -> Camera:
        """The same camera after a rigid motion ``T_new_world`` (4, 4) of the world frame."""
        T = np.asarray(T_new_world, dtype=np.float64) @ np.asarray(self.T_world_cam)
        return Camera.create(np.asarray(self.K), T, self.width, self.height)
