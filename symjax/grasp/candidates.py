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

import time
from typing import Any

import jax
import numpy as np

from symjax.array_types import ArrayLike, MeshLike
from symjax.errors import (
    DegenerateGeometryError,
    InvalidInputError,
    ShapeError,
    config_or_default,
    unknown_name,
)
from symjax.geometry import bucket, mesh_arrays, pad_rows
from symjax.grasp.approach import approach_frame, rolls_for_axes
from symjax.grasp.candidate_set import Candidates, CandidateSet
from symjax.grasp.config import CandidateConfig
from symjax.grasp.mesh_rays import cast_rays, inside_mesh

__all__ = ["METHODS", "generate", "kth_grasp_points", "start_pose_check"]

METHODS = ("openrave", "kth", "uji")


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


def kth_grasp_points(mesh: MeshLike) -> np.ndarray:
    """Two opposing grasp points: a geometric stand-in for the learned detector of [18].

    The points are where the line through the centroid along the object's narrowest horizontal
    direction leaves the mesh, so a pinch between them closes across the object's width.

    Args:
        mesh: A closed ``trimesh.Trimesh`` or ``(vertices (V, 3), faces (F, 3))``, metres.

    Returns:
        Shape (2, 3), metres.
    """
    v, f = mesh_arrays(mesh)
    c, _ = _centroid_and_axes(v, f)
    xy = v[:, :2] - c[:2]
    w, vecs = np.linalg.eigh(xy.T @ xy)
    u = np.r_[vecs[:, 0], 0.0]
    far = float(np.ptp(v, axis=0).max()) * 2 + 0.1
    origins = np.stack([c + far * u, c - far * u]).astype(np.float32)
    dirs = np.stack([-u, u]).astype(np.float32)
    t, _ = cast_rays(origins, dirs, (v, f))
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
    t, idx = cast_rays(origins, dirs, (v, f))
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
    g = kth_grasp_points((v, f)) if grasp_points is None else np.asarray(grasp_points, float)
    if g.shape != (2, 3) or not np.all(np.isfinite(g)):
        raise ShapeError(f"grasp_points must be two finite points, shape (2, 3), got {g.shape}")
    u = g[1] - g[0]
    if np.linalg.norm(u) < 1e-6:
        raise DegenerateGeometryError("the two grasp points coincide")
    u /= np.linalg.norm(u)
    d = _semicircle(u, config.n_approach, np.array([1.0, 0.0, 0.0]))
    approach = -d
    roll = rolls_for_axes(approach, u)
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
    roll = rolls_for_axes(approach, closing)
    point = np.repeat(c[None], len(approach), axis=0)
    return approach, point, roll


@jax.jit
def _probe_world(approach, point, roll, distance, probes):
    def one(a, p, r, d):
        R = approach_frame(a, r)
        return p - d * a + probes @ R.T

    return jax.vmap(one)(approach, point, roll, distance)


def start_pose_check(
    cands: Candidates, mesh: MeshLike, config: CandidateConfig, table: Any = None, hand: Any = None
) -> tuple[np.ndarray, int, int]:
    """Which candidates start clear of the table and the object (the generators' last step).

    Args:
        cands: The candidates, world frame.
        mesh: The object, ``(vertices (V, 3), faces (F, 3))`` or a ``trimesh.Trimesh``, metres.
        config: :class:`CandidateConfig` (``table_clearance``, the stand-in palm).
        table: A :class:`symjax.table.TablePlane`; None skips the table check.
        hand: A :class:`symjax.hands.Hand` whose pre-shape geometry is the probe (else a
            stand-in palm).

    Returns:
        ``(keep (N,) bool, n_dropped_table, n_dropped_object)``.
    """
    v, f = mesh_arrays(mesh)
    n = len(cands)
    keep = np.ones(n, dtype=bool)
    drop_table = drop_object = 0
    if n:
        used = sorted({int(x) for x in np.unique(np.asarray(cands.preshape))})
        if hand is not None:
            from symjax.hands import as_hand, probe_points

            hand = as_hand(hand)

            if used[-1] >= len(hand.preshape_names) or used[0] < 0:
                raise InvalidInputError(
                    f"pre-shape index {used[-1]} is out of range for the hand"
                    f" {hand.name}: expected 0 to {len(hand.preshape_names) - 1}"
                    f" ({', '.join(hand.preshape_names)})"
                )
            probes = {p: probe_points(hand, p) for p in used}
        else:
            o = config.palm_offset
            palm = np.array(
                [[0, 0, -o], [0.05, 0, -o], [-0.05, 0, -o], [0, 0.05, -o], [0, -0.05, -o]]
            )
            probes = {p: palm for p in used}
        table_bad = np.zeros(n, dtype=bool)
        object_bad = np.zeros(n, dtype=bool)
        for p, local in probes.items():
            sel = np.flatnonzero(cands.preshape == p)
            nb = bucket(len(sel), minimum=256)
            world = np.asarray(_probe_world(
                pad_rows(cands.approach[sel].astype(np.float32), nb),
                pad_rows(cands.point[sel].astype(np.float32), nb),
                pad_rows(cands.roll[sel].astype(np.float32), nb),
                pad_rows(cands.distance[sel].astype(np.float32), nb),
                np.asarray(local, np.float32),
            ))[: len(sel)]  # fmt: skip
            if table is not None:
                h = world @ np.asarray(table.normal) + float(table.offset)
                table_bad[sel] = np.any(h < config.table_clearance, axis=1)
            inside = inside_mesh(world.reshape(-1, 3), (v, f)).reshape(world.shape[:2])
            object_bad[sel] = np.any(inside, axis=1)
        drop_table = int(table_bad.sum())
        object_bad &= ~table_bad
        drop_object = int(object_bad.sum())
        keep = ~(table_bad | object_bad)
    return keep, drop_table, drop_object


def generate(
    mesh: MeshLike,
    method: str,
    *,
    config: CandidateConfig | None = None,
    table: Any = None,
    hand: Any = None,
    grasp_points: ArrayLike = None,
    seed: int = 0,
) -> CandidateSet:
    """Grasp candidates for one object mesh (``GetGraspCandidates``).

    Args:
        mesh: The object, a ``trimesh.Trimesh`` or ``(vertices (V, 3), faces (F, 3))``, metres,
            world frame (table-aligned); it should be closed for the inside test.
        method: ``"openrave"``, ``"kth"`` or ``"uji"`` (see the module docstring).
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
    config = config_or_default(config, CandidateConfig)
    if method not in METHODS:
        raise unknown_name("candidate method", method, METHODS)
    v, f = mesh_arrays(mesh)
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

    keep, drop_table, drop_object = start_pose_check(cands, (v, f), config, table, hand)
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
