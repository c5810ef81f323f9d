"""Synthetic multi-object table-top frames with ground truth, for tests and benchmarks."""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from symjax.camera import Camera
from symjax.errors import InvalidInputError

__all__ = ["CLUTTER_KINDS", "SyntheticScene", "clutter_scene", "tabletop_scene"]

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
        contacts: Pairs ``(i, j)`` of objects whose footprints are within 1 mm of each other
            (:func:`clutter_scene`; empty for :func:`tabletop_scene`).
        owner: The object each primitive belongs to (:func:`clutter_scene`; a bottle is two).
        recipe: The :func:`clutter_scene` arguments that rebuild it.
        rgb: (H, W, 3) uint8 colour image (:func:`clutter_scene`; None otherwise).
    """

    depth: np.ndarray
    camera: Camera
    truth: np.ndarray
    primitives: tuple
    table_height: float
    contacts: tuple[tuple[int, int], ...] = ()
    owner: tuple[int, ...] = ()
    recipe: dict = dataclasses.field(default_factory=dict)
    rgb: np.ndarray | None = None


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


# ---------------------------------------------------------------------------------------------
# Touching objects and clutter

#: Object kinds of :func:`clutter_scene`.
CLUTTER_KINDS = ("box", "can", "bottle")
_POLY = 48  # sides of a round footprint (inscribed: touching round objects overlap by < 0.1 mm)


def _draw_object(kind: str, rng: np.random.Generator) -> dict:
    if kind == "box":
        half = (rng.uniform(0.03, 0.06), rng.uniform(0.025, 0.05), rng.uniform(0.04, 0.09))
        return {"kind": kind, "half": half, "yaw": rng.uniform(0, math.pi)}
    if kind in ("can", "bottle"):
        out = {"kind": kind, "r": rng.uniform(0.03, 0.045), "h": rng.uniform(0.04, 0.08)}
        if kind == "bottle":
            out |= {"r": rng.uniform(0.03, 0.04), "h": rng.uniform(0.05, 0.08)}
            out |= {"neck_r": 0.4 * out["r"], "neck_h": rng.uniform(0.02, 0.035)}
        return out
    raise InvalidInputError(
        f"unknown clutter object kind {kind!r}; expected one of {CLUTTER_KINDS}"
    )


def _footprint(obj: dict, xy: np.ndarray) -> np.ndarray:
    """The object's footprint on the table as a convex polygon (k, 2), counter-clockwise."""
    if obj["kind"] == "box":
        a, b, _ = obj["half"]
        c, s = math.cos(obj["yaw"]), math.sin(obj["yaw"])
        local = np.array([[a, b], [-a, b], [-a, -b], [a, -b]])
        return xy + local @ np.array([[c, s], [-s, c]])
    t = np.linspace(0, 2 * math.pi, _POLY, endpoint=False)
    return xy + obj["r"] * np.stack([np.cos(t), np.sin(t)], 1)


def _overlap(p: np.ndarray, q: np.ndarray, margin: float = 0.0) -> bool:
    """Separating-axis test of two convex polygons: True when they overlap by more than
    ``margin`` metres on every edge normal."""
    for poly in (p, q):
        e = np.roll(poly, -1, axis=0) - poly
        axes = np.stack([e[:, 1], -e[:, 0]], 1) / np.linalg.norm(e, axis=1, keepdims=True)
        a, b = p @ axes.T, q @ axes.T
        if np.any((a.max(0) - b.min(0) <= margin) | (b.max(0) - a.min(0) <= margin)):
            return False
    return True


def _primitives(obj: dict, xy: np.ndarray, table_height: float) -> list:
    from symjax.datasets.raycast import Primitive

    x, y = float(xy[0]), float(xy[1])
    if obj["kind"] == "box":
        a, b, c = obj["half"]
        return [Primitive("box", (a, b, c), (x, y, table_height + c), _yaw(obj["yaw"]))]
    r, h = obj["r"], obj["h"]
    prims = [Primitive("cylinder", (r, h), (x, y, table_height + h))]
    if obj["kind"] == "bottle":
        nz = table_height + 2 * h + obj["neck_h"]
        prims.append(Primitive("cylinder", (obj["neck_r"], obj["neck_h"]), (x, y, nz)))
    return prims


def _touching_place(placed, obj, partner: int, u: np.ndarray) -> np.ndarray:
    """Centre of ``obj`` on the ray from ``placed[partner]`` along ``u`` where it just touches."""
    c0, o0 = placed[partner]
    fp0 = _footprint(o0, c0)
    lo, hi = 0.0, 1.0
    for _ in range(40):  # bisection to 1 um
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if _overlap(fp0, _footprint(obj, c0 + mid * u)) else (lo, mid)
    return c0 + hi * u


def _colour_image(depth, truth, normals, camera: Camera, objs, seed: int) -> np.ndarray:
    """A colour image: one colour per object, a label band of another round cans and bottles
    (texture edges on a convex surface), a grey table, Lambertian shading from the camera and
    sensor noise; drawn from its own stream so that the depth noise stays as without colour."""
    from symjax.geometry import pixel_rays

    rng = np.random.default_rng([seed, 7])
    n = len(objs)
    base = rng.uniform(40, 230, (n + 1, 3))
    band = rng.uniform(40, 230, (n + 1, 3))
    lo = rng.uniform(0.02, 0.05, n + 1)
    hi = lo + rng.uniform(0.02, 0.04, n + 1)
    base[n] = band[n] = 150.0  # the table (index -1)
    T = np.asarray(camera.T_world_cam, np.float64)
    rays = pixel_rays(np.asarray(camera.K, np.float64), camera.height, camera.width) @ T[:3, :3].T
    z = depth * rays[..., 2] + T[2, 3]  # world height of each hit
    rays /= np.linalg.norm(rays, axis=-1, keepdims=True)
    shade = 0.35 + 0.65 * np.abs(np.sum(rays * normals, axis=-1))
    k = np.where(truth >= 0, truth, n)
    round_ = np.array([o["kind"] != "box" for o in objs] + [False])
    on_band = round_[k] & (z > lo[k]) & (z < hi[k])
    colour = np.where(on_band[..., None], band[k], base[k]) * shade[..., None]
    colour += rng.normal(0, 3.0, colour.shape)
    return np.where((depth > 0)[..., None], np.clip(colour, 0, 255), 0).astype(np.uint8)


def clutter_scene(
    kinds,
    seed: int = 0,
    arrangement: str = "cluster",
    distance: float = 0.8,
    elevation_deg: float = 45.0,
    width: int = 640,
    height: int = 480,
    focal: float | None = None,
    noise=None,
    table_height: float = 0.0,
    only: int | None = None,
) -> SyntheticScene:
    """Renders objects that touch each other, through the stereo noise model.

    Each object after the first is pushed against an earlier one along a direction until their
    footprints touch (bisection to 1 um) and kept where it overlaps no other object.

    Args:
        kinds: Object kinds in placement order (``"box"``, ``"can"``, ``"bottle"``).
        seed: Random seed of sizes, yaws, directions, the camera azimuth and the noise.
        arrangement: ``"side_by_side"`` (each object beside the previous one as the camera sees
            them), ``"front_back"`` (each behind the previous one, shifted sideways by up to half
            its width: partly hidden) or ``"cluster"`` (random directions and partners).
        distance: Camera distance from the scene centre, metres.
        elevation_deg: Camera elevation above the table, degrees.
        width: Image width, pixels.
        height: Image height, pixels.
        focal: Focal length, pixels (default 575 at 640 px wide, scaled with the width).
        noise: A :class:`symjax.datasets.stereo.StereoNoise` (default: the KTH head's model).
        table_height: Table top z, metres.
        only: Render this object alone (the same layout, camera and noise stream without the
            others): the reference for what clutter costs.

    Returns:
        A :class:`SyntheticScene`; ``truth`` labels objects in placement order, ``contacts``
        holds the touching pairs, ``rgb`` a colour image (see :func:`_colour_image`).
    """
    from symjax.datasets.raycast import render_depth, scene_model
    from symjax.datasets.stereo import StereoNoise, simulate_stereo

    if arrangement not in ("side_by_side", "front_back", "cluster"):
        raise InvalidInputError(
            f"unknown arrangement {arrangement!r}; expected 'side_by_side', 'front_back' or"
            " 'cluster'"
        )
    rng = np.random.default_rng(seed)
    objs = [_draw_object(k, rng) for k in kinds]
    az = rng.uniform(0, 2 * math.pi)
    view = -np.array([math.cos(az), math.sin(az)])  # camera's looking direction on the table
    side = np.array([-view[1], view[0]])
    placed: list = []
    for i, obj in enumerate(objs):
        if i == 0:
            placed.append((np.zeros(2), obj))
            continue
        for _ in range(200):
            if arrangement == "side_by_side":
                partner, u = i - 1, side * rng.choice([-1.0, 1.0]) + 0.2 * rng.normal(size=2)
            elif arrangement == "front_back":
                partner, u = i - 1, view + rng.uniform(-0.5, 0.5) * side
            else:
                partner = int(rng.integers(len(placed)))
                a = rng.uniform(0, 2 * math.pi)
                u = np.array([math.cos(a), math.sin(a)])
            u = u / np.linalg.norm(u)
            c = _touching_place(placed, obj, partner, u)
            fp = _footprint(obj, c)
            others = [j for j in range(len(placed)) if j != partner]
            if not any(_overlap(fp, _footprint(placed[j][1], placed[j][0])) for j in others):
                placed.append((c, obj))
                break
        else:
            raise InvalidInputError(f"could not place object {i} of {len(objs)} without overlap")
    centre = np.mean([c for c, _ in placed], axis=0)
    prims, owner = [], []
    for k, (c, obj) in enumerate(placed):
        p = _primitives(obj, c - centre, table_height)
        prims += p
        owner += [k] * len(p)
    el = math.radians(elevation_deg)
    target = np.array([0.0, 0.0, table_height + 0.04])
    pos = target + distance * np.array(
        [-math.cos(el) * view[0], -math.cos(el) * view[1], math.sin(el)]
    )
    f = focal if focal is not None else 575.0 * width / 640
    K = np.array([[f, 0.0, width / 2], [0.0, f, height / 2], [0.0, 0.0, 1.0]])
    cam = Camera.look_at(pos, target, K, width, height)
    shown = [i for i, o in enumerate(owner) if only is None or o == only]
    depth, gid, normals = render_depth(
        scene_model([prims[i] for i in shown], table_height=table_height), cam, normals=True
    )
    lut = np.array([-1, -1] + [owner[i] for i in shown], np.int32)  # miss, table, primitives
    truth = lut[gid + 1]
    noise = StereoNoise() if noise is None else noise
    rgb = _colour_image(depth, truth, normals, cam, [o for _, o in placed], seed)
    depth, _ = simulate_stereo(depth, truth >= 0, normals, cam, noise, 0.0915, rng)
    fps = [_footprint(o, c) for c, o in placed]
    contacts = tuple(
        (i, j)
        for i in range(len(fps))
        for j in range(i + 1, len(fps))
        if _overlap(fps[i], fps[j], margin=-0.001)
    )
    recipe = dict(
        kinds=tuple(kinds), seed=seed, arrangement=arrangement, distance=distance,
        elevation_deg=elevation_deg, width=width, height=height, focal=focal, noise=noise,
        table_height=table_height,
    )  # fmt: skip
    return SyntheticScene(
        depth, cam, truth, tuple(prims), table_height, contacts, tuple(owner), recipe, rgb
    )
