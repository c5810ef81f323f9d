"""Synthetic views of symmetric primitive objects on a table, rendered by ray casting.

Small, exact and fast: the objects of the symmetry tests, the benchmark of the search and the
embedded demo. Each object stands on the table z = 0 at the origin, so its true symmetry planes
are vertical planes through the origin.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from symjax.array_types import ArrayLike
from symjax.camera import Camera
from symjax.datasets.raycast import Primitive, render_depth, scene_model
from symjax.errors import unknown_name
from symjax.observation import Observation
from symjax.table import TablePlane

__all__ = ["K_DEFAULT", "KINDS", "symmetry_truth", "primitive_shape", "primitive_view"]

#: Intrinsics of the default 640x480 camera, pixels.
K_DEFAULT = np.array([[900.0, 0.0, 320.0], [0.0, 900.0, 240.0], [0.0, 0.0, 1.0]])

#: Object kinds :func:`primitive_shape` knows.
KINDS = ("box", "cylinder", "bottle")


def _quat_z(angle: float) -> tuple[float, float, float, float]:
    return (math.cos(angle / 2), 0.0, 0.0, math.sin(angle / 2))


def primitive_shape(kind: str, yaw: float) -> tuple[list[Primitive], list[np.ndarray]]:
    """Primitives of a symmetric object standing on z = 0, rotated by ``yaw`` (rad) about z.

    Args:
        kind: ``"box"`` (12 x 7 x 10 cm), ``"cylinder"`` (7 cm diameter, 12 cm tall) or
            ``"bottle"`` (an elliptic body 9 x 5.6 cm with a neck, 21 cm tall).
        yaw: Rotation about the table normal, radians.

    Returns:
        The primitives and the unit normals (3,) of the object's vertical symmetry planes through
        the origin (an empty list means rotationally symmetric about the z axis: any vertical
        plane through it is a symmetry plane).

    Raises:
        UnknownNameError: If ``kind`` is not one of :data:`KINDS`.
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
    raise unknown_name("primitive object", kind, KINDS)


def primitive_view(
    kind: str,
    yaw: float,
    distance: float = 0.8,
    elevation_deg: float = 40.0,
    azimuth: float = 0.0,
    noise: float = 0.0,
    seed: int = 0,
    K: ArrayLike = K_DEFAULT,
    width: int = 640,
    height: int = 480,
) -> tuple[Observation, list[np.ndarray]]:
    """Renders one view of a primitive object.

    Args:
        kind: See :func:`primitive_shape`.
        yaw: Object rotation about the table normal, radians.
        distance: Camera distance from the object's centre, metres.
        elevation_deg: Camera elevation above the table, degrees.
        azimuth: Camera azimuth about the table normal, radians.
        noise: Depth noise coefficient, 1/m: the standard deviation at depth z is
            ``noise * z**2`` metres (stereo-like growth with the square of depth).
        seed: Noise seed.
        K: Intrinsics (3, 3), pixels.
        width: Image width, pixels.
        height: Image height, pixels.

    Returns:
        ``(observation, true plane normals)``, see :func:`primitive_shape`.
    """
    prims, normals = primitive_shape(kind, yaw)
    el = math.radians(elevation_deg)
    target = np.array([0.0, 0.0, 0.05])
    pos = target + distance * np.array(
        [math.cos(el) * math.cos(azimuth), math.cos(el) * math.sin(azimuth), math.sin(el)]
    )
    cam = Camera.look_at(pos, target, K, width, height)
    depth, gid = render_depth(scene_model(prims, table_height=0.0), cam)
    mask = gid >= 1
    if noise > 0:
        rng = np.random.default_rng(seed)
        depth = np.where(depth > 0, depth + rng.normal(0, noise, depth.shape) * depth**2, 0)
    obj_depth = np.where(mask, depth, 0.0).astype(np.float32)
    pts, valid = cam.backproject(obj_depth)
    pts = np.asarray(pts)[np.asarray(valid)]
    return Observation.create(pts, cam, TablePlane.horizontal(), mask, obj_depth), normals


def symmetry_truth(true_normals: list[np.ndarray]) -> dict[str, Any]:
    """A primitive's true symmetry (planes through the origin, or the vertical axis through it)
    as the keyword arguments of :func:`symjax.metrics.plane_error`."""
    if not true_normals:
        return {"axis": (np.zeros(3), np.array([0.0, 0.0, 1.0]))}
    return {"planes": [(np.asarray(t, np.float64), 0.0) for t in true_normals]}
