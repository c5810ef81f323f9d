"""Display-free depth rendering by MuJoCo ray casting (``mj_multiRay``).

A scene is an ``mujoco.MjModel`` (built with ``mujoco.MjSpec``) holding the table and the object
geoms; every pixel's ray is cast from the camera centre, so the depth image is exact for
primitives and triangle meshes alike and needs no OpenGL context.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import mujoco
import numpy as np

from symjax.camera import Camera
from symjax.geometry import pixel_rays

__all__ = ["Primitive", "scene_model", "render_depth"]


@dataclass(frozen=True)
class Primitive:
    """A primitive geom for a test or synthetic scene.

    Attributes:
        kind: ``"box"``, ``"cylinder"``, ``"sphere"``, ``"ellipsoid"`` or ``"capsule"``.
        size: MuJoCo size parameters (half extents / radius, half length), metres.
        pos: Centre position (3,), metres, world frame.
        quat: Orientation quaternion (w, x, y, z).
    """

    kind: str
    size: Sequence[float]
    pos: Sequence[float] = (0.0, 0.0, 0.0)
    quat: Sequence[float] = (1.0, 0.0, 0.0, 0.0)


_GEOM = {
    "box": mujoco.mjtGeom.mjGEOM_BOX,
    "cylinder": mujoco.mjtGeom.mjGEOM_CYLINDER,
    "sphere": mujoco.mjtGeom.mjGEOM_SPHERE,
    "ellipsoid": mujoco.mjtGeom.mjGEOM_ELLIPSOID,
    "capsule": mujoco.mjtGeom.mjGEOM_CAPSULE,
}


def scene_model(
    primitives: Sequence[Primitive] = (),
    meshes: Sequence[Any] = (),
    table_height: float | None = 0.0,
    table_half_size: float = 2.0,
) -> mujoco.MjModel:
    """Builds a static ray-casting scene: an optional table (a box whose top is at
    ``table_height``) plus primitives and trimesh meshes (world coordinates).

    Object geoms get ids 1.. in the order primitives then meshes; the table is geom 0 when present.
    """
    from symjax.errors import unknown_name

    spec = mujoco.MjSpec()
    wb = spec.worldbody
    if table_height is not None:
        wb.add_geom(
            name="table",
            type=mujoco.mjtGeom.mjGEOM_BOX,
            size=[table_half_size, table_half_size, 0.01],
            pos=[0.0, 0.0, table_height - 0.01],
        )
    for i, p in enumerate(primitives):
        if p.kind not in _GEOM:
            raise unknown_name("primitive kind", p.kind, list(_GEOM))
        size = list(p.size) + [0.0] * (3 - len(p.size))
        wb.add_geom(
            name=f"prim{i}", type=_GEOM[p.kind], size=size, pos=list(p.pos), quat=list(p.quat)
        )
    for i, m in enumerate(meshes):
        spec.add_mesh(
            name=f"mesh{i}",
            uservert=np.asarray(m.vertices, np.float64).ravel(),
            userface=np.asarray(m.faces, np.int32).ravel(),
        )
        wb.add_geom(name=f"meshgeom{i}", type=mujoco.mjtGeom.mjGEOM_MESH, meshname=f"mesh{i}")
    return spec.compile()


def render_depth(
    model: mujoco.MjModel, camera: Camera, max_depth: float = 10.0, normals: bool = False
) -> tuple[np.ndarray, ...]:
    """Renders the depth image and per-pixel geom ids of a static scene.

    Args:
        model: Scene from :func:`scene_model` (or any model; geoms at their default pose).
        camera: Pinhole camera.
        max_depth: Rays longer than this (metres) count as misses.
        normals: Also return the hit surfaces' unit normals.

    Returns:
        ``(depth, geom_id)``: float32 (H, W) metres along the optical axis (0 = miss) and
        int32 (H, W) hit geom id (-1 = miss); with ``normals``, a third (H, W, 3) float64 array
        of world-frame normals (0 at misses).
    """
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    K = np.asarray(camera.K, np.float64)
    T = np.asarray(camera.T_world_cam, np.float64)
    dirs_cam = pixel_rays(K, camera.height, camera.width).reshape(-1, 3)
    # Ray length t along a direction with unit z in camera frame is exactly the optical depth.
    dirs = dirs_cam @ T[:3, :3].T
    scale = np.linalg.norm(dirs, axis=1)
    unit = np.ascontiguousarray(dirs / scale[:, None])
    n = unit.shape[0]
    geomid = np.full(n, -1, np.int32)
    dist = np.full(n, -1.0)
    nrm = np.zeros(3 * n) if normals else None
    mujoco.mj_multiRay(
        model,
        data,
        np.ascontiguousarray(T[:3, 3]),
        unit.ravel(),
        None,
        True,
        -1,
        geomid,
        dist,
        nrm,
        n,
        max_depth,
    )
    hit = (dist >= 0) & (geomid >= 0)
    depth = np.where(hit, dist / scale, 0.0).reshape(camera.height, camera.width)
    out = depth.astype(np.float32), np.where(hit, geomid, -1).reshape(camera.height, camera.width)
    if normals:
        nrm = np.where(hit[:, None], nrm.reshape(n, 3), 0.0)
        return (*out, nrm.reshape(camera.height, camera.width, 3))
    return out
