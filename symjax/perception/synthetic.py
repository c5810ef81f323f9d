"""Synthetic multi-object table-top frames with ground truth, for tests and benchmarks."""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from symjax.camera import Camera
from symjax.errors import InvalidInputError

__all__ = ["SyntheticScene", "tabletop_scene"]

#: Intrinsics of the synthetic 640x480 camera, pixels.
K_SCENE = np.array([[570.0, 0.0, 320.0], [0.0, 570.0, 240.0], [0.0, 0.0, 1.0]])


@dataclasses.dataclass(frozen=True)
class SyntheticScene:
    """A rendered frame and its truth.

    Attributes:
        depth: (H, W) float32 metres with sensor noise, 0 = miss.
        camera: The camera (world z up, table z = ``table_height``).
        truth: (H, W) int32: object index per pixel (0..K-1), -1 table or background.
        primitives: The objects' primitives (``symjax.datasets.raycast.Primitive``).
        table_height: Table top z, metres.
    """

    depth: np.ndarray
    camera: Camera
    truth: np.ndarray
    primitives: tuple
    table_height: float


def _yaw(a: float) -> tuple[float, float, float, float]:
    return (math.cos(a / 2), 0.0, 0.0, math.sin(a / 2))


def tabletop_scene(
    n_objects: int = 4,
    seed: int = 0,
    noise: float = 0.002,
    distance: float = 1.0,
    elevation_deg: float = 50.0,
    roll_deg: float = 10.0,
    spacing: float = 0.2,
    table_height: float = 0.0,
    width: int = 640,
    height: int = 480,
    primitives: tuple | None = None,
    camera: Camera | None = None,
) -> SyntheticScene:
    """Renders boxes, cylinders and spheres standing apart on a table by ray casting.

    Args:
        n_objects: Objects, 0 (empty table) to 9, on a jittered 3 x 3 grid of ``spacing`` metres.
        seed: Random seed of kinds, sizes, yaws, positions and noise.
        noise: Depth noise coefficient, 1/m: standard deviation ``noise * z**2`` metres.
        distance: Camera distance from the scene centre, metres.
        elevation_deg: Camera elevation above the table, degrees.
        roll_deg: Camera roll about its optical axis, degrees (tilts the table in the image).
        spacing: Grid pitch, metres.
        table_height: Table top z, metres.
        width: Image width, pixels.
        height: Image height, pixels.
        primitives: Explicit objects (``Primitive``) instead of random ones (``n_objects`` is
            then ignored).
        camera: Explicit camera instead of the one built from distance, elevation and roll.
    """
    from symjax.datasets.raycast import Primitive, render_depth, scene_model

    if primitives is None and not 0 <= n_objects <= 9:
        raise InvalidInputError(f"n_objects must be in [0, 9], got {n_objects}")
    rng = np.random.default_rng(seed)
    cells = rng.permutation(9)[:n_objects] if primitives is None else []
    prims = [] if primitives is None else list(primitives)
    for c in cells:
        x = (c % 3 - 1) * spacing + rng.uniform(-0.02, 0.02)
        y = (c // 3 - 1) * spacing + rng.uniform(-0.02, 0.02)
        kind = ("box", "cylinder", "sphere")[rng.integers(3)]
        q = _yaw(rng.uniform(0, math.pi))
        if kind == "box":
            size = (rng.uniform(0.03, 0.06), rng.uniform(0.025, 0.05), rng.uniform(0.03, 0.08))
            prims.append(Primitive("box", size, (x, y, table_height + size[2]), q))
        elif kind == "cylinder":
            size = (rng.uniform(0.025, 0.045), rng.uniform(0.03, 0.08))
            prims.append(Primitive("cylinder", size, (x, y, table_height + size[1]), q))
        else:
            r = rng.uniform(0.03, 0.05)
            prims.append(Primitive("sphere", (r,), (x, y, table_height + r), q))
    el = math.radians(elevation_deg)
    az = rng.uniform(0, 2 * math.pi)
    target = np.array([0.0, 0.0, table_height])
    pos = target + distance * np.array(
        [math.cos(el) * math.cos(az), math.cos(el) * math.sin(az), math.sin(el)]
    )
    K = K_SCENE * np.array([[width / 640], [height / 480], [1.0]])
    cam = Camera.look_at(pos, target, K, width, height)
    if roll_deg and camera is None:
        r = math.radians(roll_deg)
        Rz = np.array([[math.cos(r), -math.sin(r), 0], [math.sin(r), math.cos(r), 0], [0, 0, 1]])
        T = np.asarray(cam.T_world_cam).copy()
        T[:3, :3] = T[:3, :3] @ Rz
        cam = Camera.create(K, T, width, height)
    cam = camera if camera is not None else cam
    depth, gid = render_depth(scene_model(prims, table_height=table_height), cam)
    if noise > 0:
        depth = np.where(depth > 0, depth + rng.normal(0, 1, depth.shape) * noise * depth**2, 0)
    truth = np.where(gid >= 1, gid - 1, -1).astype(np.int32)
    return SyntheticScene(depth.astype(np.float32), cam, truth, tuple(prims), table_height)
