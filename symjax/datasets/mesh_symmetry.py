"""The true symmetry planes of a mesh perpendicular to the table, found and verified.

Candidate planes come from the mesh; a plane is kept when the mirrored mesh deviates from the
original by less than ``MeshSymmetryConfig.threshold`` (3 mm) on average (see
:func:`detect_symmetry`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np

from symjax.array_types import ArrayLike, MeshLike
from symjax.datasets.preprocess import area_centroid
from symjax.errors import (
    DegenerateGeometryError,
)
from symjax.geometry import reflect
from symjax.metrics import surface_distance
from symjax.validation import check_fields

__all__ = [
    "MeshSymmetryConfig",
    "SymmetryInfo",
    "detect_symmetry",
    "is_symmetry_plane",
    "mirror_deviation",
    "mirror_distances",
]


@dataclass(frozen=True)
class MeshSymmetryConfig:
    """Detection and verification of vertical reflection symmetry planes of a mesh.

    Attributes:
        threshold: A plane is a symmetry when the mean distance of the mirrored surface to the
            original surface is below this, metres (3 mm: about the scan noise plus label relief).
        tail_quantile: Quantile of the mirrored distances that must stay below ``tail_threshold``.
        tail_threshold: Bound of that quantile, metres: a mean alone would accept a plane that
            mirrors a small part (a mug handle) into empty space.
        coarse_step_deg: Angle step of the coarse scan over [0, 180) deg.
        refine_step_deg: Angle step of the local refinement around coarse minima.
        offset_range: Offsets searched around the centroid in refinement, +- metres.
        offset_step: Offset step of the refinement, metres.
        n_query: Surface samples mirrored per candidate plane.
        n_reference: Dense surface samples the mirrored points are matched to (coarse scan).
        n_verify: Samples of the exact verification (distance to the mesh triangles).
        seed: Seed of the surface sampling (the detection is deterministic).
    """

    threshold: float = 0.003
    tail_quantile: float = 0.98
    tail_threshold: float = 0.01
    coarse_step_deg: float = 1.0
    refine_step_deg: float = 0.1
    offset_range: float = 0.006
    offset_step: float = 0.0005
    n_query: int = 1000
    n_reference: int = 60000
    n_verify: int = 6000
    seed: int = 0

    def __post_init__(self) -> None:
        check_fields(self)


@dataclass(frozen=True)
class SymmetryInfo:
    """True symmetry of an object in its canonical frame (planes perpendicular to the table).

    Attributes:
        kind: ``"rotational"`` (every vertical plane through the vertical axis at ``axis_xy`` is a
            symmetry plane), ``"planar"`` (the planes listed) or ``"none"``.
        planes: ``(normal (3,), offset)`` of each verified plane ``{x : normal . x = offset}``,
            metres, canonical frame (empty unless ``kind == "planar"``).
        deviations: Mean mirrored-mesh deviation of each plane, metres; for ``"rotational"`` the
            largest deviation over the sampled planes through the axis.
        axis_xy: Table position (2,) of the rotation axis, metres (``"rotational"`` only).
        best_deviation: Smallest deviation found over all vertical planes, metres (also when no
            plane passes, to document how far the object is from symmetric).
    """

    kind: Literal["none", "planar", "rotational"]
    planes: tuple[tuple[tuple[float, float, float], float], ...] = ()
    deviations: tuple[float, ...] = ()
    axis_xy: tuple[float, float] | None = None
    best_deviation: float = float("nan")

    def to_json(self) -> dict[str, Any]:
        return {
            "kind": self.kind,
            "planes": [[list(n), o] for n, o in self.planes],
            "deviations": list(self.deviations),
            "axis_xy": None if self.axis_xy is None else list(self.axis_xy),
            "best_deviation": self.best_deviation,
        }

    @classmethod
    def from_json(cls, d: dict[str, Any]) -> SymmetryInfo:
        return cls(
            kind=d["kind"],
            planes=tuple((tuple(float(v) for v in n), float(o)) for n, o in d["planes"]),
            deviations=tuple(float(v) for v in d["deviations"]),
            axis_xy=None if d["axis_xy"] is None else tuple(float(v) for v in d["axis_xy"]),
            best_deviation=float(d["best_deviation"]),
        )


def mirror_distances(
    mesh: MeshLike, normal: ArrayLike, offset: float, n_samples: int = 8000, seed: int = 0
) -> np.ndarray:
    """Distances of the mirrored mesh surface to the original surface.

    Surface samples (uniform by area) are reflected across ``{x : normal . x = offset}`` and their
    distances to the original triangles are measured (:func:`surface_distance`, an upper bound).

    Args:
        mesh: ``trimesh.Trimesh``.
        normal: Plane normal (3,) (normalised here).
        offset: Plane offset, metres.
        n_samples: Surface samples.
        seed: Sampling seed.

    Returns:
        Distances (n_samples,), metres.
    """
    import trimesh

    n = np.asarray(normal, np.float64)
    nn = np.linalg.norm(n)
    if nn < 1e-12:
        raise DegenerateGeometryError("plane normal has zero length")
    n = n / nn
    pts, _ = trimesh.sample.sample_surface(mesh, n_samples, seed=seed)
    d = surface_distance(reflect(np.asarray(pts), n, float(offset)), mesh, candidates=12)
    return d


def mirror_deviation(
    mesh: MeshLike, normal: ArrayLike, offset: float, n_samples: int = 8000, seed: int = 0
) -> float:
    """Mean of :func:`mirror_distances`, metres: the symmetry score of a plane."""
    return float(mirror_distances(mesh, normal, offset, n_samples, seed).mean())


def is_symmetry_plane(
    mesh: MeshLike,
    normal: ArrayLike,
    offset: float,
    config: MeshSymmetryConfig = MeshSymmetryConfig(),
    seed: int = 0,
) -> tuple[bool, float, float]:
    """The symmetry criterion: is ``{x : normal . x = offset}`` a reflection symmetry of the mesh?

    True when the mirrored surface deviates from the original by less than ``config.threshold``
    on average and its ``config.tail_quantile`` stays below ``config.tail_threshold``.

    Returns:
        ``(is_symmetry, mean deviation (m), tail quantile (m))``.
    """
    d = mirror_distances(mesh, normal, offset, config.n_verify, seed)
    mean, tail = float(d.mean()), float(np.quantile(d, config.tail_quantile))
    return bool(mean < config.threshold and tail < config.tail_threshold), mean, tail


def detect_symmetry(
    mesh: MeshLike, config: MeshSymmetryConfig = MeshSymmetryConfig()
) -> SymmetryInfo:
    """Finds and verifies the vertical reflection symmetry planes of a canonical mesh.

    Candidate planes pass through the table-projected area centroid (the centroid of a symmetric
    surface lies on every one of its symmetry planes) with normals every ``coarse_step_deg`` over
    [0, 180). Each is scored by the mean distance of mirrored samples to dense samples of the
    original surface. The object is rotational when every angle scores below the threshold and
    the exact check passes on spread angles; otherwise each clear local minimum is refined in
    angle and offset and verified with the exact point-to-triangle distance
    (:func:`mirror_distances`): a plane is a symmetry when the mean distance is below
    ``threshold`` and the ``tail_quantile`` below ``tail_threshold``.

    Args:
        mesh: Canonical ``trimesh.Trimesh`` (z up, table at z = 0).
        config: Detection settings.

    Returns:
        The object's :class:`SymmetryInfo`.
    """
    import trimesh
    from scipy.spatial import cKDTree

    ref, _ = trimesh.sample.sample_surface(mesh, config.n_reference, seed=config.seed)
    qry, _ = trimesh.sample.sample_surface(mesh, config.n_query, seed=config.seed + 1)
    ref, qry = np.asarray(ref), np.asarray(qry)
    tree = cKDTree(ref)
    c = area_centroid(mesh)
    c[2] = 0.0

    def normal(alpha: float) -> np.ndarray:
        return np.array([math.cos(alpha), math.sin(alpha), 0.0])

    # Far-off mirrored points are slow to match and only need to count as "far": distances are
    # truncated (scores of poor planes saturate, good planes are unaffected).
    cap = 4.0 * config.threshold

    def score(alpha: float, offset: float) -> float:
        n = normal(alpha)
        d, _ = tree.query(reflect(qry, n, float(n @ c) + offset), distance_upper_bound=cap)
        return float(np.minimum(d, cap).mean())

    def verify(n: np.ndarray, off: float) -> tuple[float, bool]:
        ok, mean, _ = is_symmetry_plane(mesh, n, off, config, seed=config.seed + 2)
        return mean, ok

    angles = np.deg2rad(np.arange(0.0, 180.0, config.coarse_step_deg))
    coarse = np.array([score(a, 0.0) for a in angles])
    # Nearest-sample distances overestimate the surface distance by about half the sample
    # spacing; the scan keeps candidates with that slack, the exact verification decides.
    slack = config.threshold + math.sqrt(mesh.area / config.n_reference)
    best = math.inf
    if np.all(coarse < slack):
        n_ang = len(angles)
        checks = sorted({int(np.argmax(coarse)), *range(0, n_ang, max(1, n_ang // 6))})
        results = [verify(normal(angles[i]), float(normal(angles[i]) @ c)) for i in checks]
        if all(ok for _, ok in results):
            devs = [m for m, _ in results]
            return SymmetryInfo(
                kind="rotational",
                deviations=(max(devs),),
                axis_xy=(float(c[0]), float(c[1])),
                best_deviation=min(devs),
            )
    # Clear local minima: the smallest score within +-5 deg (the scores of scans are rough).
    n_ang = len(angles)
    win = max(1, int(round(5.0 / config.coarse_step_deg)))
    minima = [
        i
        for i in range(n_ang)
        if coarse[i] < slack
        and all(coarse[i] <= coarse[(i + k) % n_ang] for k in range(-win, win + 1))
    ]
    fine = np.deg2rad(
        np.arange(-config.coarse_step_deg, config.coarse_step_deg + 1e-9, config.refine_step_deg)
    )
    offsets = np.arange(-config.offset_range, config.offset_range + 1e-12, config.offset_step)
    found: list[tuple[float, tuple[tuple[float, float, float], float]]] = []
    for i in minima:
        cand = angles[i] + fine
        a_best = float(min(cand, key=lambda a: score(float(a), 0.0)))
        o_best = float(min(offsets, key=lambda o: score(a_best, float(o))))
        a_best = float(min(cand, key=lambda a: score(float(a), o_best)))
        n = normal(a_best)
        off = float(n @ c + o_best)
        dev, ok = verify(n, off)
        best = min(best, dev)
        if ok:
            # Canonical sign: the normal's largest component is positive.
            if n[int(np.argmax(np.abs(n)))] < 0:
                n, off = -n, -off
            found.append((dev, ((float(n[0]), float(n[1]), 0.0), off)))
    if not found:
        return SymmetryInfo(
            kind="none", best_deviation=best if math.isfinite(best) else float(coarse.min())
        )
    found.sort(key=lambda t: abs(math.atan2(t[1][0][1], t[1][0][0])))
    return SymmetryInfo(
        kind="planar",
        planes=tuple(p for _, p in found),
        deviations=tuple(d for d, _ in found),
        best_deviation=best,
    )


# ----------------------------------------------------------------------------------------------
# Object models with an on-disk cache
# ----------------------------------------------------------------------------------------------
