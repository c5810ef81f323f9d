"""Rays against triangle meshes: first hits (the OpenRAVE sampler, the KTH grasp points) and the
inside test (start poses), one Moller-Trumbore kernel for both.

Rays, points and triangles are padded to size buckets (:func:`symjax.geometry.bucket`) so that
the jitted kernels compile once per bucket, not once per mesh; padded triangles have zero area
and are never hit.
"""

from __future__ import annotations

from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

from symjax.array_types import ArrayLike, MeshLike
from symjax.errors import (
    ShapeError,
)
from symjax.geometry import bucket, mesh_arrays, pad_rows

__all__ = ["cast_rays", "inside_mesh", "ray_mesh"]


def _ray_triangles(origin, direction, triangles, t_min: float):
    """Moller-Trumbore for one ray against every triangle (T, 3, 3).

    Returns:
        ``(t, hit)``, each (T,): ray parameter and whether the ray hits the triangle at
        ``t > t_min``.
    """
    v0, v1, v2 = triangles[:, 0], triangles[:, 1], triangles[:, 2]
    e1, e2 = v1 - v0, v2 - v0
    p = jnp.cross(direction, e2)
    det = jnp.sum(e1 * p, axis=-1)
    ok = jnp.abs(det) > 1e-12
    inv = jnp.where(ok, 1.0 / jnp.where(ok, det, 1.0), 0.0)
    s = origin - v0
    u = jnp.sum(s * p, axis=-1) * inv
    # v = d.(s x e1); t = e2.(s x e1) = s.(e1 x e2). Writing t with the unbatched normal keeps
    # (s x e1) out of two reductions: XLA on the CPU fused those two across a vmapped batch and
    # gave every ray after the first the first ray's e2.(s x e1) (jax 0.10, >= 20k triangles).
    v = jnp.sum(jnp.cross(s, e1) * direction, axis=-1) * inv
    t = jnp.sum(s * jnp.cross(e1, e2), axis=-1) * inv
    return t, ok & (u >= 0) & (v >= 0) & (u + v <= 1) & (t > t_min)


def ray_mesh(
    origin: jax.Array, direction: jax.Array, triangles: jax.Array
) -> tuple[jax.Array, jax.Array]:
    """First hit of one ray with a triangle soup (Moller-Trumbore).

    Args:
        origin: Shape (3,). direction: shape (3,), need not be unit.
        triangles: Shape (T, 3, 3), vertices of each triangle.

    Returns:
        ``(t, index)``: ray parameter of the nearest hit with ``t > 0`` (``inf`` if none) and
        the triangle index (-1 if none).
    """
    t, hit = _ray_triangles(origin, direction, triangles, t_min=1e-9)
    t = jnp.where(hit, t, jnp.inf)
    i = jnp.argmin(t)
    return t[i], jnp.where(jnp.isfinite(t[i]), i, -1)


def _crossings(point, triangles):
    # A direction no mesh edge or face is likely to be aligned with.
    d = jnp.array([0.5773503, 0.5773502, 0.5773504]) + jnp.array([1e-3, -2e-3, 3e-3])
    _, hit = _ray_triangles(point, d, triangles, t_min=0.0)
    return jnp.sum(hit)


@jax.jit
def _rays_jit(origins, directions, triangles):
    return jax.lax.map(
        lambda od: ray_mesh(od[0], od[1], triangles), (origins, directions), batch_size=64
    )


@jax.jit
def _inside_jit(points, triangles):
    n = jax.lax.map(lambda p: _crossings(p, triangles), points, batch_size=128)
    return n % 2 == 1


def _triangles(mesh: Any) -> np.ndarray:
    """(T', 3, 3) float32 triangles padded to a bucket with zero-area copies of a vertex."""
    v, f = mesh_arrays(mesh)
    tri = v[f].astype(np.float32)
    n = bucket(len(tri), minimum=256)
    if n == len(tri):
        return tri
    filler = np.repeat(tri[:1, :1], 3, axis=1)  # det = 0: never hit, never a crossing
    return np.concatenate([tri, np.repeat(filler, n - len(tri), axis=0)])


def cast_rays(
    origins: ArrayLike, directions: ArrayLike, mesh: MeshLike
) -> tuple[np.ndarray, np.ndarray]:
    """First hits of many rays with a mesh.

    Args:
        origins: (R, 3) ray origins, metres.
        directions: (R, 3) directions (need not be unit).
        mesh: A ``trimesh.Trimesh`` or ``(vertices (V, 3), faces (F, 3))``.

    Returns:
        ``(t (R,), face (R,))``: ray parameter of the nearest hit with ``t > 0`` (``inf`` where
        none) and the hit face index (-1 where none).
    """
    o = np.asarray(origins, np.float32).reshape(-1, 3)
    d = np.asarray(directions, np.float32).reshape(-1, 3)
    if o.shape != d.shape:
        raise ShapeError(f"origins {o.shape} and directions {d.shape} must match")
    tri = _triangles(mesh)
    n = bucket(len(o), minimum=64)
    t, idx = _rays_jit(pad_rows(o, n), pad_rows(d, n), tri)
    return np.asarray(t)[: len(o)], np.asarray(idx)[: len(o)]


def inside_mesh(points: ArrayLike, mesh: MeshLike) -> np.ndarray:
    """Whether points lie inside a closed triangle mesh (ray parity).

    Args:
        points: (P, 3) points, metres (any leading shape is flattened).
        mesh: A closed ``trimesh.Trimesh`` or ``(vertices (V, 3), faces (F, 3))``.

    Returns:
        (P,) bool.
    """
    pts = np.asarray(points, dtype=np.float32).reshape(-1, 3)
    v, f = mesh_arrays(mesh)
    out = np.zeros(len(pts), dtype=bool)
    lo, hi = v.min(0), v.max(0)
    cand = np.flatnonzero(np.all((pts >= lo) & (pts <= hi), axis=1))
    if len(cand):
        res = _inside_jit(pad_rows(pts[cand], bucket(len(cand), minimum=64)), _triangles((v, f)))
        out[cand] = np.asarray(res)[: len(cand)]
    return out
