"""Synthetic single-object table views of symmetric primitives, rendered by ray casting."""

from __future__ import annotations

import math

import numpy as np

from symjax import Camera, Observation, TablePlane
from symjax.datasets.raycast import Primitive, render_depth, scene_model

K_DEFAULT = np.array([[900.0, 0.0, 320.0], [0.0, 900.0, 240.0], [0.0, 0.0, 1.0]])


def _quat_z(angle: float) -> tuple[float, float, float, float]:
    return (math.cos(angle / 2), 0.0, 0.0, math.sin(angle / 2))


def shape(kind: str, yaw: float) -> tuple[list[Primitive], list[np.ndarray]]:
    """Primitives of a symmetric object standing on z = 0 rotated by ``yaw`` about z.

    Returns the primitives and the normals (3,) of the object's vertical symmetry planes through
    the origin (empty list = rotationally symmetric about the z axis: any vertical plane
    through it).
    """
    q = _quat_z(yaw)
    c, s = math.cos(yaw), math.sin(yaw)
    ex, ey = np.array([c, s, 0.0]), np.array([-s, c, 0.0])
    if kind == "box":
        return [Primitive("box", (0.06, 0.035, 0.05), (0, 0, 0.05), q)], [ex, ey]
    if kind == "cylinder":
        return [Primitive("cylinder", (0.035, 0.06), (0, 0, 0.06), q)], []
    if kind == "bottle":
        return [
            Primitive("ellipsoid", (0.045, 0.028, 0.08), (0, 0, 0.08), q),
            Primitive("cylinder", (0.012, 0.03), (0, 0, 0.18), q),
        ], [ex, ey]
    raise KeyError(kind)


def view(
    kind: str,
    yaw: float,
    distance: float = 0.8,
    elevation_deg: float = 40.0,
    azimuth: float = 0.0,
    noise: float = 0.0,
    seed: int = 0,
    K: np.ndarray = K_DEFAULT,
):
    """Renders one view; returns (observation, true plane normals)."""
    prims, normals = shape(kind, yaw)
    el = math.radians(elevation_deg)
    target = np.array([0.0, 0.0, 0.05])
    pos = target + distance * np.array(
        [math.cos(el) * math.cos(azimuth), math.cos(el) * math.sin(azimuth), math.sin(el)]
    )
    cam = Camera.look_at(pos, target, K, 640, 480)
    model = scene_model(prims, table_height=0.0)
    depth, gid = render_depth(model, cam)
    mask = gid >= 1
    if noise > 0:
        rng = np.random.default_rng(seed)
        depth = np.where(depth > 0, depth + rng.normal(0, noise, depth.shape) * depth**2, 0)
    obj_depth = np.where(mask, depth, 0.0).astype(np.float32)
    pts, valid = cam.backproject(obj_depth)
    pts = np.asarray(pts)[np.asarray(valid)]
    obs = Observation.create(pts, cam, TablePlane.horizontal(), mask, obj_depth)
    return obs, normals


def plane_error(normal, offset, true_normals) -> tuple[float, float]:
    """Angle (deg) and offset (m) error of a plane against the object's true planes through the
    origin; for rotational objects, the plane's distance from the axis (angle error 0)."""
    normal = np.asarray(normal, np.float64)
    offset = float(offset)
    if not true_normals:
        return 0.0, abs(offset)
    best = (180.0, np.inf)
    for t in true_normals:
        ang = math.degrees(math.acos(min(1.0, abs(float(normal @ t)))))
        if ang < best[0]:
            best = (ang, abs(offset))
    return best
