"""Grasp candidates: the paper's ``GetGraspCandidates`` (Section IV-A) and OpenRAVE's default.

A candidate is an approach vector (unit, the direction the hand moves), a grasp point (the TCP
moves along the approach line through it), a roll about the approach, a pre-shape index and an
approach distance. The TCP frame of a candidate is :func:`approach_frame`: its z axis is the
approach and its x axis, set by the roll, the hand's closing axis (thumb to fingers, jaw to
jaw; see :mod:`symjax.hands`).

Generators:

* ``"openrave"``: the object's bounding box surface is sampled uniformly, a ray per sample is
  cast into the box, and at each hit the approach is the inward surface normal (Fig. 4 left),
  with evenly spaced rolls.
* ``"kth"``: two grasp points; approaches on the semicircle (0 to 180 deg) whose normal is the
  line between them, centred at their midpoint; the roll aligns the closing axis with that line.
* ``"uji"``: a semicircle centred at the object's centroid with the major eigenvector as
  normal, plus a perpendicular one containing the major axis. The closing axis is
  perpendicular to the major axis (the circle tangent on the first, the normal on the second),
  so the thumb-finger line passes through the centroid across the object (paper III-B.2).

Candidates whose start pose puts a hand probe point below the table or inside the object are
dropped and counted.
"""

from __future__ import annotations

import dataclasses
import time
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

from symjax._pytree import pytree_dataclass
from symjax.errors import (
    DegenerateGeometryError,
    EmptyInputError,
    InvalidInputError,
    ShapeError,
    unknown_name,
)
from symjax.grasp.config import CandidateConfig

__all__ = [
    "METHODS",
    "CandidateSet",
    "Candidates",
    "approach_frame",
    "generate",
    "inside_mesh",
    "kth_grasp_points",
    "ray_mesh",
    "roll_for_axis",
]

METHODS = ("openrave", "kth", "uji")


@pytree_dataclass
class Candidates:
    """A batch of N grasp candidates (every field's leading axis is N).

    Attributes:
        approach: Unit approach vectors, shape (N, 3); the hand moves along them.
        point: Grasp points, shape (N, 3), metres, world frame.
        roll: Roll about the approach, shape (N,), radians (see :func:`approach_frame`).
        preshape: Pre-shape indices into ``symjax.hands.PRESHAPES``, shape (N,), int32.
        distance: Approach distance, shape (N,), metres: the TCP starts at
            ``point - distance * approach``.
    """

    approach: Any
    point: Any
    roll: Any
    preshape: Any
    distance: Any

    def __len__(self) -> int:
        return int(np.shape(self.roll)[0])

    def frames(self):
        """TCP orientations, shape (N, 3, 3): columns are closing axis, y, approach."""
        return jax.vmap(approach_frame)(jnp.asarray(self.approach), jnp.asarray(self.roll))

    def start_positions(self):
        """TCP start positions ``point - distance * approach``, shape (N, 3), metres."""
        return self.point - self.distance[:, None] * self.approach


@dataclasses.dataclass(frozen=True)
class CandidateSet:
    """Output of :func:`generate`.

    Attributes:
        candidates: The kept candidates.
        method: The generator used.
        n_generated: Candidates before the start-pose check.
        n_dropped_table: Dropped because the hand started in (or under) the table.
        n_dropped_object: Dropped because the hand started inside the object.
        n_missed: ``"openrave"`` rays that missed the object (no candidate made).
        seconds: Wall time of the call.
    """

    candidates: Candidates
    method: str
    n_generated: int
    n_dropped_table: int
    n_dropped_object: int
    n_missed: int
    seconds: float

    def __len__(self) -> int:
        return len(self.candidates)


def _reference_axes(a):
    """Two unit vectors spanning the plane normal to unit ``a``: world z projected, then a x z."""
    ref = jnp.where(jnp.abs(a[2]) < 0.99, jnp.array([0.0, 0.0, 1.0]), jnp.array([1.0, 0.0, 0.0]))
    e1 = ref - jnp.dot(ref, a) * a
    e1 = e1 / jnp.linalg.norm(e1)
    return e1, jnp.cross(a, e1)


def approach_frame(approach, roll):
    """TCP orientation of one candidate, shape (3, 3).

    The z column is ``approach``; the x column (closing axis) is ``cos(roll) e1 + sin(roll) e2``
    with ``e1`` the world z axis (world x if the approach is vertical) projected normal to the
    approach and ``e2 = approach x e1``.

    Args:
        approach: Unit vector, shape (3,).
        roll: Radians, scalar.
    """
    a = approach / jnp.linalg.norm(approach)
    e1, e2 = _reference_axes(a)
    x = jnp.cos(roll) * e1 + jnp.sin(roll) * e2
    return jnp.stack([x, jnp.cross(a, x), a], axis=-1)


def roll_for_axis(approach, axis):
    """The roll that points the closing axis along ``axis`` (projected normal to the approach)."""
    a = approach / jnp.linalg.norm(approach)
    e1, e2 = _reference_axes(a)
    return jnp.arctan2(jnp.dot(axis, e2), jnp.dot(axis, e1))


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
    q = jnp.cross(s, e1)
    v = (q @ direction) * inv
    t = jnp.sum(e2 * q, axis=-1) * inv
    return t, ok & (u >= 0) & (v >= 0) & (u + v <= 1) & (t > t_min)


def ray_mesh(origin, direction, triangles):
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


def _bucket(n: int) -> int:
    # Pad batches to powers of two so that repeated calls reuse a few compiled programs.
    return max(64, 1 << (int(n) - 1).bit_length())


def _pad(x: np.ndarray, n: int) -> np.ndarray:
    return np.concatenate([x, np.repeat(x[-1:], n - len(x), axis=0)]) if n > len(x) else x


def inside_mesh(points: Any, vertices: Any, faces: Any) -> np.ndarray:
    """Whether points lie inside a closed triangle mesh (ray parity), shape (P,) bool."""
    pts = np.asarray(points, dtype=np.float32).reshape(-1, 3)
    tri = np.asarray(vertices, dtype=np.float32)[np.asarray(faces)]
    out = np.zeros(len(pts), dtype=bool)
    lo, hi = tri.reshape(-1, 3).min(0), tri.reshape(-1, 3).max(0)
    cand = np.flatnonzero(np.all((pts >= lo) & (pts <= hi), axis=1))
    if len(cand):
        res = _inside_jit(_pad(pts[cand], _bucket(len(cand))), tri)
        out[cand] = np.asarray(res)[: len(cand)]
    return out


def _check_mesh(vertices: Any, faces: Any) -> tuple[np.ndarray, np.ndarray]:
    v = np.asarray(vertices, dtype=np.float64)
    f = np.asarray(faces)
    if v.ndim != 2 or v.shape[1] != 3 or f.ndim != 2 or f.shape[1] != 3:
        raise ShapeError(f"mesh must be vertices (V, 3) and faces (F, 3), got {v.shape}, {f.shape}")
    if len(v) < 4 or len(f) < 4:
        raise EmptyInputError(f"mesh too small: {len(v)} vertices, {len(f)} faces")
    if not np.all(np.isfinite(v)):
        raise DegenerateGeometryError("mesh vertices contain NaN or inf")
    if not np.issubdtype(f.dtype, np.integer) or f.min() < 0 or f.max() >= len(v):
        raise ShapeError("faces must be integer indices into vertices")
    return v, f.astype(np.int64)


def _centroid_and_axes(v: np.ndarray, f: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Volume centroid (area centroid if the mesh is open) and principal axes, major first."""
    a, b, c = v[f[:, 0]], v[f[:, 1]], v[f[:, 2]]
    vol = np.einsum("ij,ij->i", a, np.cross(b, c)) / 6.0
    area = 0.5 * np.linalg.norm(np.cross(b - a, c - a), axis=1)
    if area.sum() <= 0:
        raise DegenerateGeometryError("mesh has zero area")
    tc = (a + b + c) / 3.0
    if abs(vol.sum()) > 1e-12:
        centroid = (vol[:, None] * (a + b + c) / 4.0).sum(0) / vol.sum()
    else:
        centroid = (area[:, None] * tc).sum(0) / area.sum()
    x = tc - centroid
    cov = (area[:, None, None] * (x[:, :, None] * x[:, None, :])).sum(0) / area.sum()
    w, vecs = np.linalg.eigh(cov)
    return centroid, vecs[:, np.argsort(w)[::-1]].T


def _semicircle(normal: np.ndarray, n: int, fallback: np.ndarray) -> np.ndarray:
    """n unit directions over 0..180 deg on the circle normal to ``normal``, upper half first."""
    normal = normal / np.linalg.norm(normal)
    b1 = np.cross(normal, [0.0, 0.0, 1.0])
    if np.linalg.norm(b1) < 1e-6:  # horizontal circle: no "upper half", start at fallback
        b1 = fallback - np.dot(fallback, normal) * normal
    b1 /= np.linalg.norm(b1)
    b2 = np.cross(normal, b1)
    if b2[2] < 0:
        b2 = -b2
    th = np.linspace(0.0, np.pi, n) if n > 1 else np.array([np.pi / 2])
    return np.cos(th)[:, None] * b1 + np.sin(th)[:, None] * b2


def kth_grasp_points(vertices: Any, faces: Any) -> np.ndarray:
    """Two opposing grasp points: a geometric stand-in for the learned detector of [18].

    The points are where the line through the centroid along the object's narrowest horizontal
    direction leaves the mesh, so a pinch between them closes across the object's width.

    Returns:
        Shape (2, 3), metres.
    """
    v, f = _check_mesh(vertices, faces)
    c, _ = _centroid_and_axes(v, f)
    xy = v[:, :2] - c[:2]
    w, vecs = np.linalg.eigh(xy.T @ xy)
    u = np.r_[vecs[:, 0], 0.0]
    tri = v[f].astype(np.float32)
    far = float(np.ptp(v, axis=0).max()) * 2 + 0.1
    origins = np.stack([c + far * u, c - far * u]).astype(np.float32)
    dirs = np.stack([-u, u]).astype(np.float32)
    t, idx = (np.asarray(x) for x in _rays_jit(origins, dirs, tri))
    if not np.all(np.isfinite(t)):
        raise DegenerateGeometryError("no surface found across the centroid")
    return origins + t[:, None] * dirs


def _expand(approach, point, roll, config: CandidateConfig) -> Candidates:
    """Cartesian product of (approach, point, roll) rows with pre-shapes and distances."""
    A = len(approach)
    P, D = len(config.preshapes), len(config.distances)
    rep = P * D
    return Candidates(
        approach=np.repeat(approach, rep, axis=0),
        point=np.repeat(point, rep, axis=0),
        roll=np.repeat(roll, rep),
        preshape=np.tile(np.repeat(np.asarray(config.preshapes, np.int32), D), A),
        distance=np.tile(np.asarray(config.distances, np.float64), A * P),
    )


def _openrave(v, f, config: CandidateConfig, rng: np.random.Generator):
    lo = v.min(0) - config.box_padding
    hi = v.max(0) + config.box_padding
    size = hi - lo
    # Six faces: (axis, side); area-proportional sampling of the box surface.
    faces = [(ax, side) for ax in range(3) for side in (0, 1)]
    areas = np.array([np.prod(np.delete(size, ax)) for ax, _ in faces])
    pick = rng.choice(6, size=config.n_rays, p=areas / areas.sum())
    origins = lo + rng.random((config.n_rays, 3)) * size
    dirs = np.zeros((config.n_rays, 3))
    for k, (ax, side) in enumerate(faces):
        sel = pick == k
        origins[sel, ax] = hi[ax] if side else lo[ax]
        dirs[sel, ax] = -1.0 if side else 1.0
    tri = v[f].astype(np.float32)
    nb = _bucket(config.n_rays)
    t, idx = (np.asarray(x) for x in _rays_jit(
        _pad(origins.astype(np.float32), nb), _pad(dirs.astype(np.float32), nb), tri
    ))  # fmt: skip
    t, idx = t[: config.n_rays], idx[: config.n_rays]
    hit = np.isfinite(t)
    p = origins[hit] + t[hit, None] * dirs[hit]
    a, b, c = (v[f[idx[hit], k]] for k in range(3))
    n = np.cross(b - a, c - a)
    n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-12)
    # The hand moves into the surface: against the normal that faces the ray's origin.
    approach = np.where(np.einsum("ij,ij->i", n, dirs[hit])[:, None] < 0, -n, n)
    rolls = 2 * np.pi * np.arange(config.n_rolls) / config.n_rolls
    H = len(p)
    approach = np.repeat(approach, config.n_rolls, axis=0)
    point = np.repeat(p, config.n_rolls, axis=0)
    roll = np.tile(rolls, H)
    return approach, point, roll, int((~hit).sum())


def _kth(v, f, config: CandidateConfig, grasp_points):
    g = kth_grasp_points(v, f) if grasp_points is None else np.asarray(grasp_points, float)
    if g.shape != (2, 3) or not np.all(np.isfinite(g)):
        raise ShapeError(f"grasp_points must be two finite points, shape (2, 3), got {g.shape}")
    u = g[1] - g[0]
    if np.linalg.norm(u) < 1e-6:
        raise DegenerateGeometryError("the two grasp points coincide")
    u /= np.linalg.norm(u)
    d = _semicircle(u, config.n_approach, np.array([1.0, 0.0, 0.0]))
    approach = -d
    roll = np.asarray(jax.vmap(roll_for_axis, (0, None))(jnp.asarray(approach), jnp.asarray(u)))
    point = np.repeat(g.mean(0)[None], len(d), axis=0)
    return approach, point, roll


def _uji(v, f, config: CandidateConfig):
    c, axes = _centroid_and_axes(v, f)
    ea, eb = axes[0], axes[1]
    d1 = _semicircle(ea, config.n_approach, eb)
    a1 = -d1
    closing1 = np.cross(ea, a1)  # circle tangent: across the major axis
    n2 = np.cross(ea, [0.0, 0.0, 1.0])
    n2 = eb if np.linalg.norm(n2) < 1e-6 else n2 / np.linalg.norm(n2)
    d2 = _semicircle(n2, config.n_approach, ea)
    a2 = -d2
    closing2 = np.repeat(n2[None], len(d2), axis=0)
    approach = np.concatenate([a1, a2])
    closing = np.concatenate([closing1, closing2])
    roll = np.asarray(jax.vmap(roll_for_axis)(jnp.asarray(approach), jnp.asarray(closing)))
    point = np.repeat(c[None], len(approach), axis=0)
    return approach, point, roll


@jax.jit
def _probe_world(approach, point, roll, distance, probes):
    def one(a, p, r, d):
        R = approach_frame(a, r)
        return p - d * a + probes @ R.T

    return jax.vmap(one)(approach, point, roll, distance)


def generate(
    method: str,
    vertices: Any,
    faces: Any,
    *,
    config: CandidateConfig | None = None,
    table: Any = None,
    hand: Any = None,
    grasp_points: Any = None,
    seed: int = 0,
) -> CandidateSet:
    """Grasp candidates for one object mesh (``GetGraspCandidates``).

    Args:
        method: ``"openrave"``, ``"kth"`` or ``"uji"`` (see the module docstring).
        vertices: Object mesh vertices, shape (V, 3), metres, world frame (table-aligned).
        faces: Triangles, shape (F, 3); the mesh should be closed for the inside test.
        config: Counts, distances and pre-shapes (default :class:`CandidateConfig`).
        table: A :class:`symjax.table.TablePlane`; None skips the table check.
        hand: A :class:`symjax.hands.Hand`; its geometry at each pre-shape is the start-pose
            probe (else a stand-in palm, see :class:`CandidateConfig`).
        grasp_points: ``"kth"`` only: the two grasp points, shape (2, 3); default
            :func:`kth_grasp_points`.
        seed: Seed of the ``"openrave"`` box sampling (the circles are deterministic).

    Returns:
        A :class:`CandidateSet`. Counts before dropping: ``"kth"`` ``n_approach * P * D``,
        ``"uji"`` twice that, ``"openrave"`` ``hits * n_rolls * P * D`` (P pre-shapes, D
        distances).
    """
    t0 = time.perf_counter()
    config = config if config is not None else CandidateConfig()
    if method not in METHODS:
        raise unknown_name("candidate method", method, METHODS)
    v, f = _check_mesh(vertices, faces)
    if grasp_points is not None and method != "kth":
        raise InvalidInputError("grasp_points only applies to method 'kth'")
    n_missed = 0
    if method == "openrave":
        approach, point, roll, n_missed = _openrave(v, f, config, np.random.default_rng(seed))
    elif method == "kth":
        approach, point, roll = _kth(v, f, config, grasp_points)
    else:
        approach, point, roll = _uji(v, f, config)
    cands = _expand(approach, point, roll, config)
    n = len(cands)

    keep = np.ones(n, dtype=bool)
    drop_table = drop_object = 0
    if n:
        if hand is not None:
            from symjax.hands import probe_points

            if max(config.preshapes) >= len(hand.preshape_names):
                raise InvalidInputError(f"pre-shape index out of range for hand {hand.name}")
            probes = {p: probe_points(hand, p) for p in set(config.preshapes)}
        else:
            o = config.palm_offset
            palm = np.array(
                [[0, 0, -o], [0.05, 0, -o], [-0.05, 0, -o], [0, 0.05, -o], [0, -0.05, -o]]
            )
            probes = {p: palm for p in set(config.preshapes)}
        table_bad = np.zeros(n, dtype=bool)
        object_bad = np.zeros(n, dtype=bool)
        for p, local in probes.items():
            sel = np.flatnonzero(cands.preshape == p)
            world = np.asarray(_probe_world(
                jnp.asarray(cands.approach[sel]), jnp.asarray(cands.point[sel]),
                jnp.asarray(cands.roll[sel]), jnp.asarray(cands.distance[sel]),
                jnp.asarray(local),
            ))  # fmt: skip
            if table is not None:
                h = world @ np.asarray(table.normal) + float(table.offset)
                table_bad[sel] = np.any(h < config.table_clearance, axis=1)
            inside = inside_mesh(world.reshape(-1, 3), v, f).reshape(world.shape[:2])
            object_bad[sel] = np.any(inside, axis=1)
        drop_table = int(table_bad.sum())
        object_bad &= ~table_bad
        drop_object = int(object_bad.sum())
        keep = ~(table_bad | object_bad)
    kept = jax.tree_util.tree_map(lambda x: x[keep], cands)
    kept = Candidates(
        approach=kept.approach.astype(np.float32),
        point=kept.point.astype(np.float32),
        roll=kept.roll.astype(np.float32),
        preshape=kept.preshape.astype(np.int32),
        distance=kept.distance.astype(np.float32),
    )
    return CandidateSet(
        candidates=kept,
        method=method,
        n_generated=n,
        n_dropped_table=drop_table,
        n_dropped_object=drop_object,
        n_missed=n_missed,
        seconds=time.perf_counter() - t0,
    )
