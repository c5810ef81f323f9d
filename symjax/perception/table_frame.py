"""The world frame of a segmentation whose camera has no pose: the table's."""

from __future__ import annotations

import dataclasses

import numpy as np

from symjax.camera import Camera

__all__ = ["in_table_frame"]


def in_table_frame(scene, camera: Camera):
    """``scene`` (a :class:`TableScene`) as is when ``camera`` has a pose, else re-expressed in
    the table frame: z along the table normal towards the camera, origin on the table below the
    objects' centroid (a metre along the optical axis when there are none), x along the optical
    axis projected on the table."""
    if np.allclose(np.asarray(camera.T_world_cam, np.float64), np.eye(4)):
        return _to_table_frame(scene, camera)
    return scene


def _to_table_frame(scene, camera: Camera):
    """The scene re-expressed in the table frame (see :attr:`TableScene.frame`)."""
    z = np.asarray(scene.table.normal, np.float64)
    cam = np.asarray(camera.T_world_cam, np.float64)
    x = cam[:3, 2] - (cam[:3, 2] @ z) * z  # the optical axis on the table
    if np.linalg.norm(x) < 1e-6:  # looking straight down
        x = np.cross(z, [0.0, 1.0, 0.0] if abs(z[1]) < 0.9 else [1.0, 0.0, 0.0])
    x /= np.linalg.norm(x)
    if scene.objects:
        c = np.mean([i.centroid for i in scene.info], axis=0)
    else:
        c = cam[:3, 3] + cam[:3, 2]  # a metre along the optical axis
    origin = c - (c @ z + float(scene.table.offset)) * z
    R = np.stack([x, np.cross(z, x), z])  # rows: the new axes in the input frame
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = R, -R @ origin
    infos = tuple(
        dataclasses.replace(i, centroid=R @ np.asarray(i.centroid) + T[:3, 3]) for i in scene.info
    )
    return dataclasses.replace(
        scene,
        table=scene.table.transformed(T),
        objects=tuple(o.transformed(T) for o in scene.objects),
        info=infos,
        frame="table",
        T_world_input=T,
    )
