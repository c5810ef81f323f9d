"""Geometry shared by every stage: pixel rays, back-projection, reflection, rotations, buckets.

Conventions: pinhole intrinsics ``K`` (3, 3) in pixels with skew ``K[0, 1]``; camera frame x
right, y down, z along the optical axis; ``T_world_cam`` (4, 4) maps camera to world; depth is
metres along the optical axis; planes are ``{x : normal . x = offset}``; rotations are (3, 3)
matrices acting on column vectors. Functions take numpy arrays unless marked JAX; the JAX ones
work on one example and are batched with ``vmap`` by their callers.
"""

from __future__ import annotations

import math
from typing import Any

import jax.numpy as jnp
import numpy as np

from symjax.array_types import ArrayLike, MeshLike
from symjax.errors import DegenerateGeometryError, EmptyInputError, InvalidInputError, ShapeError

__all__ = [
    "as_pose",
    "as_trimesh",
    "axis_rotation",
    "backproject",
    "bucket",
    "closest_point_on_triangle",
    "euler_zyx",
    "is_closed",
    "mesh_arrays",
    "pad_rows",
    "pixel_rays",
    "quat_to_matrix",
    "reflect",
    "rot_z",
    "rot_zyx",
    "rotation_angle",
    "rotation_angle_np",
]


def pixel_rays(K: ArrayLike, height: int, width: int, xp: Any = np) -> Any:
    """Camera-frame ray of every pixel centre, scaled to unit z.

    Args:
        K: (3, 3) intrinsics, pixels.
        height: Image rows.
        width: Image columns.
        xp: ``numpy`` (float64) or ``jax.numpy`` (float32).

    Returns:
        (height, width, 3) rays ``[x/z, y/z, 1]``: a ray times the depth is the camera point.
    """
    K = xp.asarray(K)
    v, u = xp.meshgrid(
        xp.arange(height, dtype=K.dtype), xp.arange(width, dtype=K.dtype), indexing="ij"
    )
    yn = (v - K[1, 2]) / K[1, 1]
    xn = (u - K[0, 2] - K[0, 1] * yn) / K[0, 0]
    return xp.stack([xn, yn, xp.ones_like(xn)], axis=-1)


def backproject(
    depth: np.ndarray, K: ArrayLike, T_world_cam: ArrayLike, select: ArrayLike = None
) -> np.ndarray:
    """World points of the pixels of a depth image.

    Args:
        depth: (H, W) depth, metres along the optical axis.
        K: (3, 3) intrinsics, pixels.
        T_world_cam: (4, 4) camera-to-world pose.
        select: Optional (H, W) bool mask of the pixels to keep (default: depth > 0).

    Returns:
        (M, 3) float64 world points, metres, in row-major pixel order of the selection.
    """
    depth = np.asarray(depth)
    sel = depth > 0 if select is None else np.asarray(select, bool)
    rays = pixel_rays(np.asarray(K, np.float64), *depth.shape)[sel]
    T = np.asarray(T_world_cam, np.float64)
    return (rays * depth[sel].astype(np.float64)[:, None]) @ T[:3, :3].T + T[:3, 3]


def tangent_basis(n: ArrayLike, xp: Any = np) -> tuple[Any, Any]:
    """Two unit tangents (3,) orthogonal to the unit normal ``n`` (3,) and to each other; ``xp``
    is numpy or jax.numpy (traceable, for ``vmap``)."""
    ref = xp.where(xp.abs(n[0]) < 0.9, xp.array([1.0, 0.0, 0.0]), xp.array([0.0, 1.0, 0.0]))
    t1 = ref - xp.dot(ref, n) * n
    t1 = t1 / xp.linalg.norm(t1)
    return t1, xp.cross(n, t1)


def reflect(points: ArrayLike, normal: ArrayLike, offset: ArrayLike) -> Any:
    """Mirrors points (..., 3) across the plane ``{x : normal . x = offset}`` (Eq. 2).

    Works on numpy and JAX arrays alike; ``normal`` (3,) must be a unit vector.
    """
    dist = points @ normal - offset
    return points - 2.0 * dist[..., None] * normal[None, :]


def axis_rotation(axis: ArrayLike, angle: float) -> np.ndarray:
    """Rotation matrix (3, 3) by ``angle`` radians about the unit ``axis`` (3,) (Rodrigues)."""
    a = np.asarray(axis, np.float64)
    k = np.array([[0.0, -a[2], a[1]], [a[2], 0.0, -a[0]], [-a[1], a[0], 0.0]])
    return np.eye(3) + math.sin(angle) * k + (1.0 - math.cos(angle)) * (k @ k)


def rot_z(angle: float) -> np.ndarray:
    """(3, 3) rotation by ``angle`` radians about the world z axis (the table normal)."""
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def euler_zyx(R: ArrayLike) -> Any:
    """JAX: intrinsic z-y-x angles (a, b, c) with ``R = Rz(a) Ry(b) Rx(c)``, shape (..., 3).

    At gimbal lock (the x axis vertical) only ``a + c`` or ``a - c`` is defined; ``a`` is then 0.
    """
    cb = jnp.sqrt(R[..., 0, 0] ** 2 + R[..., 1, 0] ** 2)
    b = jnp.arctan2(-R[..., 2, 0], cb)
    lock = cb < 1e-6
    a = jnp.where(lock, 0.0, jnp.arctan2(R[..., 1, 0], R[..., 0, 0]))
    c = jnp.where(
        lock, jnp.arctan2(-R[..., 1, 2], R[..., 1, 1]), jnp.arctan2(R[..., 2, 1], R[..., 2, 2])
    )
    return jnp.stack([a, b, c], axis=-1)


def rot_zyx(e: ArrayLike) -> Any:
    """JAX: rotation matrices (..., 3, 3) of intrinsic z-y-x angles (..., 3), the inverse of
    :func:`euler_zyx`."""
    a, b, c = e[..., 0], e[..., 1], e[..., 2]
    ca, sa, cb, sb, cc, sc = jnp.cos(a), jnp.sin(a), jnp.cos(b), jnp.sin(b), jnp.cos(c), jnp.sin(c)
    return jnp.stack(
        [
            jnp.stack([ca * cb, ca * sb * sc - sa * cc, ca * sb * cc + sa * sc], -1),
            jnp.stack([sa * cb, sa * sb * sc + ca * cc, sa * sb * cc - ca * sc], -1),
            jnp.stack([-sb, cb * sc, cb * cc], -1),
        ],
        axis=-2,
    )


def quat_to_matrix(q: ArrayLike) -> Any:
    """JAX: rotation matrices (..., 3, 3) of unit quaternions (..., 4), MuJoCo's (w, x, y, z)."""
    w, x, y, z = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    return jnp.stack(
        [
            jnp.stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)], -1),
            jnp.stack([2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)], -1),
            jnp.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], -1),
        ],
        axis=-2,
    )


def rotation_angle(Ra: ArrayLike, Rb: ArrayLike) -> Any:
    """JAX: angle (radians) of the rotation between two (3, 3) rotations."""
    c = (jnp.trace(Ra.T @ Rb) - 1.0) / 2.0
    return jnp.arccos(jnp.clip(c, -1.0, 1.0))


def bucket(n: int, minimum: int = 256) -> int:
    """Rounds a count up to one of few sizes so that jitted functions are reused.

    Sizes are ``2^k * {1, 1.25, 1.5, 1.75}``: at most 25% padding (a power of two alone would
    waste up to half of the work, e.g. 40,000 -> 65,536), while the number of distinct compiled
    shapes stays logarithmic (32 sizes from 1,000 to 200,000 points, 4 per doubling).

    Args:
        n: The count.
        minimum: The smallest size returned.
    """
    n = max(int(n), int(minimum))
    k = int(np.floor(np.log2(n)))
    for step in (4, 5, 6, 7, 8):
        size = (step << k) // 4
        if size >= n:
            return size
    raise AssertionError("unreachable")  # step 8 is 2^(k+1) > n


def cloud_bucket(n: int, minimum: int = 1024) -> int:
    """The padded size of a point cloud for the symmetry search and the Poisson solve.

    Powers of two: eight sizes cover 1,000 to 200,000 points, so a robot meeting objects of every
    size compiles each kernel a handful of times. The padding costs the search at most an
    eighth more (its kernel loops over slabs of points and stops after the last valid one,
    :mod:`symjax.symmetry.scoring`) and the Poisson solve little (its grid, not its points,
    dominates at depth 7).

    Args:
        n: Points in the cloud.
        minimum: The smallest size returned.
    """
    return max(int(minimum), 1 << (max(int(n), 1) - 1).bit_length())


def pad_rows(x: np.ndarray, n: int) -> np.ndarray:
    """Pads the leading axis to ``n`` rows by repeating the last row (a valid, ignored input).

    Args:
        x: (m, ...) array with m >= 1.
        n: Rows wanted, n >= m.
    """
    x = np.asarray(x)
    m = x.shape[0]
    if m == n:
        return x
    return np.concatenate([x, np.repeat(x[-1:], n - m, axis=0)], axis=0)


def mesh_arrays(mesh: MeshLike, what: str = "mesh") -> tuple[np.ndarray, np.ndarray]:
    """The one accepted mesh input, as checked arrays.

    Args:
        mesh: A ``trimesh.Trimesh`` or a ``(vertices (V, 3), faces (F, 3))`` pair, metres.
        what: The argument's name, for messages.

    Returns:
        ``(vertices float64 (V, 3), faces int64 (F, 3))``, C-contiguous.

    Raises:
        InvalidInputError: Neither a Trimesh nor a pair.
        ShapeError: Wrong shapes or face indices out of range.
        EmptyInputError: Fewer than 4 vertices or faces.
        DegenerateGeometryError: NaN or inf vertices.
    """
    if hasattr(mesh, "vertices") and hasattr(mesh, "faces"):
        vertices, faces = mesh.vertices, mesh.faces
    elif isinstance(mesh, (tuple, list)) and len(mesh) == 2:
        vertices, faces = mesh
    else:
        raise InvalidInputError(
            f"{what} must be a trimesh.Trimesh or a (vertices (V, 3), faces (F, 3)) pair, got"
            f" {type(mesh).__name__}"
        )
    v = np.ascontiguousarray(vertices, dtype=np.float64)
    f = np.asarray(faces)
    if f.size and f.dtype.kind not in "iu":
        raise ShapeError(f"{what} faces must be integer vertex indices, got dtype {f.dtype}")
    f = np.ascontiguousarray(f, dtype=np.int64)
    if v.ndim != 2 or v.shape[1] != 3:
        raise ShapeError(f"{what} vertices must have shape (V, 3), got {v.shape}")
    if f.ndim != 2 or f.shape[1] != 3:
        raise ShapeError(f"{what} faces must have shape (F, 3), got {f.shape}")
    if len(v) < 4 or len(f) < 4:
        raise EmptyInputError(f"{what} needs >= 4 vertices and faces, got {len(v)} and {len(f)}")
    if not np.all(np.isfinite(v)):
        raise DegenerateGeometryError(f"{what} vertices contain NaN or inf")
    if f.min() < 0 or f.max() >= len(v):
        raise ShapeError(
            f"{what} face indices must lie in [0, {len(v)}), got [{f.min()}, {f.max()}]"
        )
    return v, f


def as_trimesh(mesh: MeshLike, what: str = "mesh"):
    """The one accepted mesh input as a ``trimesh.Trimesh`` (returned as is when it is one)."""
    import trimesh

    if isinstance(mesh, trimesh.Trimesh):
        return mesh
    v, f = mesh_arrays(mesh, what)
    return trimesh.Trimesh(v, f, process=False)


def as_pose(pose: ArrayLike, what: str = "pose") -> tuple[np.ndarray, np.ndarray]:
    """``(position (3,), rotation (3, 3))`` of a rigid pose, float64.

    Args:
        pose: A (4, 4) homogeneous matrix, or ``(x, y, z, qw, qx, qy, qz)`` (a unit
            quaternion, MuJoCo's order), metres.
        what: The argument's name, for the messages.

    Raises:
        ShapeError: Neither shape.
        InvalidInputError: NaN or inf, a rotation that is not orthonormal or a zero quaternion.
    """
    a = np.asarray(pose, np.float64)
    if not np.all(np.isfinite(a)):
        raise InvalidInputError(f"{what} contains NaN or inf")
    if a.shape == (4, 4):
        R, p = a[:3, :3], a[:3, 3]
        if np.abs(R @ R.T - np.eye(3)).max() > 1e-5 or np.linalg.det(R) < 0:
            raise InvalidInputError(f"{what}: the upper-left 3 x 3 block is not a rotation")
        return p.copy(), R.copy()
    if a.shape == (7,):
        q = a[3:]
        n = np.linalg.norm(q)
        if n < 1e-9:
            raise InvalidInputError(f"{what}: the quaternion (qw, qx, qy, qz) is zero")
        return a[:3].copy(), np.asarray(quat_to_matrix(q / n), np.float64)
    raise ShapeError(f"{what} must be a (4, 4) matrix or (x, y, z, qw, qx, qy, qz), got {a.shape}")


def rotation_angle_np(Ra: ArrayLike, Rb: ArrayLike) -> float:
    """Angle (radians) of the rotation between two (3, 3) rotations, numpy float64."""
    c = (np.trace(np.asarray(Ra, np.float64).T @ np.asarray(Rb, np.float64)) - 1.0) / 2.0
    return float(np.arccos(np.clip(c, -1.0, 1.0)))


def is_closed(faces: np.ndarray, n_vertices: int) -> bool:
    """Watertight with consistent winding: each directed edge once, and its reverse once.

    The same test as ``trimesh``'s ``is_watertight and is_winding_consistent``, several times
    cheaper on marching-cubes meshes of 10^5 faces.
    """
    a = faces.reshape(-1).astype(np.int64)
    b = np.roll(faces, -1, axis=1).reshape(-1).astype(np.int64)
    # Each undirected edge exactly twice, once each way: one sort of (edge, direction) keys.
    key = np.sort((np.minimum(a, b) * n_vertices + np.maximum(a, b)) * 2 + (a > b))
    if key.size % 2:
        return False
    first, second = key[0::2], key[1::2]
    return bool(
        np.all(first >> 1 == second >> 1)
        and np.all(first & 1 == 0)
        and np.all(second & 1 == 1)
        and np.all(first[1:] >> 1 > second[:-1] >> 1)
    )


def closest_point_on_triangle(p: ArrayLike, tri: ArrayLike) -> np.ndarray:
    """Closest point of each triangle to its point (Ericson, Real-Time Collision Detection,
    5.1.5: the Voronoi region of the point decides vertex, edge or face), numpy float64.

    Degenerate triangles (zero area) give a closest point of their edges.

    Args:
        p: (N, 3) points.
        tri: (N, 3, 3) triangles, vertex by row.

    Returns:
        (N, 3) closest points.
    """
    p = np.asarray(p, np.float64)
    a, b, c = (np.asarray(tri, np.float64)[:, k] for k in range(3))
    ab, ac = b - a, c - a

    def dot(u, v):
        return np.einsum("ij,ij->i", u, v)

    def ratio(num, den):
        return np.clip(num / np.where(den == 0.0, 1.0, den), 0.0, 1.0)[:, None]

    d1, d2 = dot(ab, p - a), dot(ac, p - a)
    d3, d4 = dot(ab, p - b), dot(ac, p - b)
    d5, d6 = dot(ab, p - c), dot(ac, p - c)
    va, vb, vc = d3 * d6 - d5 * d4, d5 * d2 - d1 * d6, d1 * d4 - d3 * d2
    den = va + vb + vc
    inside = a + ab * ratio(vb, den) + ac * ratio(vc, den)
    # np.select takes the first true region, in Ericson's order.
    regions = [
        (d1 <= 0) & (d2 <= 0),
        (d3 >= 0) & (d4 <= d3),
        (vc <= 0) & (d1 >= 0) & (d3 <= 0),
        (d6 >= 0) & (d5 <= d6),
        (vb <= 0) & (d2 >= 0) & (d6 <= 0),
        (va <= 0) & (d4 - d3 >= 0) & (d5 - d6 >= 0),
        den == 0.0,  # degenerate with p beside it: the closest of its three edges
    ]
    points = [
        a,
        b,
        a + ab * ratio(d1, d1 - d3),
        c,
        a + ac * ratio(d2, d2 - d6),
        b + (c - b) * ratio(d4 - d3, (d4 - d3) + (d5 - d6)),
        _closest_on_edges(p, a, b, c),
    ]
    return np.select([r[:, None] for r in regions], points, inside)


def _closest_on_edges(p: np.ndarray, a: np.ndarray, b: np.ndarray, c: np.ndarray) -> np.ndarray:
    best, best_d = a, np.full(len(p), np.inf)
    for u, v in ((a, b), (b, c), (c, a)):
        e = v - u
        den = np.einsum("ij,ij->i", e, e)
        t = np.clip(np.einsum("ij,ij->i", p - u, e) / np.where(den == 0, 1, den), 0, 1)
        q = u + e * t[:, None]
        d = np.einsum("ij,ij->i", p - q, p - q)
        best = np.where((d < best_d)[:, None], q, best)
        best_d = np.minimum(d, best_d)
    return best
