"""A dense grasp sampler that covers the grasp space, as the field's data sets sample it.

Two kinds of candidate, half each:

* **antipodal** (ACRONYM, GraspGen): a surface point, the ray into the object along its inward
  normal to where it leaves the object; the grasp point is the middle of that chord, the closing
  axis the chord, the approach a random direction perpendicular to it;
* **approach** (the paper's OpenRAVE generator, densified): a surface point, the approach its
  inward normal tilted at random within a cone, a random roll.

Each candidate gets a pre-shape and a start distance drawn from the config's, counted from where
the approach line leaves the object's convex hull behind the grasp point (an antipodal grasp
point lies inside the object; the hand starts outside it and travels in until it stalls).
Candidates whose start pose is in the table or the object are dropped
(:func:`symjax.grasp.start_pose_check`) and more are drawn until the count is reached.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any

import numpy as np

from symjax.array_types import MeshLike
from symjax.errors import ConfigError, DegenerateGeometryError
from symjax.geometry import mesh_arrays
from symjax.validation import check_fields

__all__ = ["DenseSamplerConfig", "dense_candidates"]


@dataclasses.dataclass(frozen=True)
class DenseSamplerConfig:
    """Parameters of :func:`dense_candidates`.

    Attributes:
        antipodal_share: Share of antipodal candidates (the rest are approach candidates).
        cone_deg: Half-angle of the cone around the inward normal of approach candidates, deg.
        preshapes: Pre-shape indices drawn from (into ``symjax.hands.PRESHAPES``).
        distances: Start distances drawn from, metres beyond ``clearance``.
        clearance: Gap between the object's hull and the TCP at the start, metres.
        max_rounds: Rounds of drawing (each sized by the previous rounds' share of clear start
            poses) before giving up on reaching ``n``.
    """

    antipodal_share: float = 0.5
    cone_deg: float = 30.0
    preshapes: tuple[int, ...] = (1, 2)
    distances: tuple[float, ...] = (0.0, 0.05)
    clearance: float = 0.01
    max_rounds: int = 6

    def __post_init__(self) -> None:
        check_fields(self)
        if not 0.0 <= self.antipodal_share <= 1.0:
            raise ConfigError(f"antipodal_share must be in [0, 1], got {self.antipodal_share}")
        if not 0.0 <= self.cone_deg < 90.0:
            raise ConfigError(f"cone_deg must be in [0, 90), got {self.cone_deg}")
        if not self.preshapes or any(p < 0 for p in self.preshapes):
            raise ConfigError(f"preshapes must be non-empty indices, got {self.preshapes}")
        if not self.distances or any(not 0.0 <= d <= 1.0 for d in self.distances):
            raise ConfigError(f"distances must be non-empty, in [0, 1] m, got {self.distances}")
        if not 0.0 <= self.clearance <= 0.2:
            raise ConfigError(f"clearance must be in [0, 0.2] m, got {self.clearance}")
        if self.max_rounds < 1:
            raise ConfigError(f"max_rounds must be >= 1, got {self.max_rounds}")


def _perpendicular(u: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """A random unit vector perpendicular to each row of ``u`` (N, 3)."""
    ref = np.where(np.abs(u[:, 2:3]) < 0.9, [[0.0, 0.0, 1.0]], [[1.0, 0.0, 0.0]])
    b1 = np.cross(u, ref)
    b1 /= np.linalg.norm(b1, axis=1, keepdims=True)
    b2 = np.cross(u, b1)
    th = rng.uniform(0.0, 2 * np.pi, len(u))[:, None]
    return np.cos(th) * b1 + np.sin(th) * b2


def _tilted(n: np.ndarray, cone: float, rng: np.random.Generator) -> np.ndarray:
    """Each row of ``n`` tilted by an angle uniform in solid angle within ``cone`` radians."""
    cos_t = rng.uniform(math.cos(cone), 1.0, len(n))[:, None]
    sin_t = np.sqrt(1.0 - cos_t**2)
    return cos_t * n + sin_t * _perpendicular(n, rng)


def _draw(v, f, hull, k: int, cfg: DenseSamplerConfig, rng: np.random.Generator):
    """k raw candidates: (approach, point, roll, preshape, distance) arrays."""
    from symjax.grasp.approach import rolls_for_axes
    from symjax.grasp.mesh_rays import cast_rays

    a, b, c = v[f[:, 0]], v[f[:, 1]], v[f[:, 2]]
    cross = np.cross(b - a, c - a)
    area = 0.5 * np.linalg.norm(cross, axis=1)
    face = rng.choice(len(f), size=k, p=area / area.sum())
    r1, r2 = rng.random(k), rng.random(k)
    s = np.sqrt(r1)[:, None]
    p = (1 - s) * a[face] + s * (1 - r2[:, None]) * b[face] + s * r2[:, None] * c[face]
    normal = cross[face] / np.maximum(2 * area[face], 1e-12)[:, None]  # outward (fixed mesh)
    approach = _tilted(-normal, math.radians(cfg.cone_deg), rng)
    point = p.copy()
    roll = rng.uniform(0.0, 2 * np.pi, k)
    anti = rng.random(k) < cfg.antipodal_share
    if anti.any():
        idx = np.flatnonzero(anti)
        origin = (p[idx] - 1e-4 * normal[idx]).astype(np.float32)
        t, _ = cast_rays(origin, (-normal[idx]).astype(np.float32), (v, f))
        hit = np.isfinite(t) & (t > 1e-3)
        idx, t = idx[hit], t[hit]
        if len(idx):
            u = -normal[idx]
            point[idx] = p[idx] + 0.5 * t[:, None] * u
            approach[idx] = _perpendicular(u, rng)
            roll[idx] = rolls_for_axes(approach[idx], u)
    preshape = rng.choice(np.asarray(cfg.preshapes, np.int32), size=k)
    # How far the hull reaches behind the grasp point along the approach: max (p - h) . a.
    behind = np.einsum("kj,kj->k", point, approach) - (hull @ approach.T).min(axis=0)
    distance = np.maximum(behind, 0.0) + cfg.clearance + rng.choice(
        np.asarray(cfg.distances, np.float64), size=k)  # fmt: skip
    return approach, point, roll, preshape, distance


def dense_candidates(
    mesh: MeshLike,
    n: int,
    *,
    config: DenseSamplerConfig | None = None,
    table: Any = None,
    hand: Any = None,
    seed: int = 0,
    candidate_config: Any = None,
):
    """``n`` candidates that start clear of the table and the object (fewer if the rounds run out).

    Args:
        mesh: The closed object mesh, ``trimesh.Trimesh`` or ``(vertices, faces)``, metres, with
            outward face winding.
        n: Candidates wanted.
        config: :class:`DenseSamplerConfig`.
        table: :class:`symjax.table.TablePlane` or None.
        hand: :class:`symjax.hands.Hand` whose pre-shape geometry is the start-pose probe.
        seed: Seed of the draw; the same seed gives the same candidates.
        candidate_config: :class:`symjax.grasp.CandidateConfig` of the start-pose check.

    Returns:
        ``(Candidates, n_drawn)``: the candidates in draw order and how many were drawn.

    Raises:
        DegenerateGeometryError: The mesh has no area.
    """
    from symjax.grasp import CandidateConfig, Candidates
    from symjax.grasp.candidates import start_pose_check

    cfg = config if config is not None else DenseSamplerConfig()
    ccfg = candidate_config if candidate_config is not None else CandidateConfig()
    v, f = mesh_arrays(mesh)
    if len(f) == 0 or not np.all(np.isfinite(v)):
        raise DegenerateGeometryError("the mesh has no faces or non-finite vertices")
    import trimesh

    hull = np.asarray(trimesh.Trimesh(v, f, process=False).convex_hull.vertices, np.float64)
    rng = np.random.default_rng(seed)
    parts: list[Any] = []
    have = drawn = 0
    rate = 0.5  # share of draws that start clear; updated from each round
    for _ in range(cfg.max_rounds):
        if have >= n:
            break
        k = max(int(np.ceil(1.25 * (n - have) / max(rate, 0.02))), 64)
        a, p, r, ps, d = _draw(v, f, hull, k, cfg, rng)
        c = Candidates(approach=a.astype(np.float32), point=p.astype(np.float32),
                       roll=r.astype(np.float32), preshape=ps.astype(np.int32),
                       distance=d.astype(np.float32))  # fmt: skip
        drawn += k
        keep, _, _ = start_pose_check(c, (v, f), ccfg, table, hand)
        c = c.take(keep)
        parts.append(c)
        have += len(c)
        rate = max(len(parts[-1]), 1) / k
    out = Candidates.concatenate(parts)
    return out.take(np.arange(min(n, len(out)))), drawn
