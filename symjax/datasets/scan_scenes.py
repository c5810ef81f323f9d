"""Seeded table scenes for the grasp cycle: YCB scans dropped on a robot's table, settled with
MuJoCo, seen by the robot's head camera through the stereo noise model.

Objects are placed in the arm's workspace without overlapping footprints (some nearly touching),
dropped from a few millimetres and simulated until they rest: each rests on its convex hull,
as a real object on a flat table does. The depth image is ray-cast from the head camera of the
robot's MJCF and made noisy by :func:`symjax.datasets.stereo.simulate_stereo`; the ground truth
(meshes and poses in the world frame, a per-pixel object label) is kept with the scene.
"""

from __future__ import annotations

import dataclasses
from typing import Any

import mujoco
import numpy as np

from symjax.camera import Camera
from symjax.errors import InvalidInputError, SimulationError

__all__ = ["SCENE_OBJECTS", "ScanScene", "head_camera", "rearranged", "scan_scene"]

#: Scans that stand on a table and fit a hand: the benchmark's upright objects and others.
SCENE_OBJECTS = (
    "003_cracker_box", "004_sugar_box", "005_tomato_soup_can", "006_mustard_bottle",
    "010_potted_meat_can", "021_bleach_cleanser", "022_windex_bottle", "025_mug",
    "002_master_chef_can", "065-a_cups", "013_apple", "024_bowl",
)  # fmt: skip

_WORKSPACE = ((0.5, 0.8), (-0.3, 0.3))  # x, y ranges on the table in front of both arms, metres


@dataclasses.dataclass(frozen=True)
class ScanScene:
    """One seeded table scene and its ground truth.

    Attributes:
        robot: ``"kth"`` or ``"uji"``.
        names: The objects' scan names, in label order.
        poses: Object-to-world transforms, shape (k, 4, 4) (the scans' canonical frames).
        meshes: The true meshes in the world frame (``trimesh.Trimesh``), in label order.
        camera: The robot's head camera.
        depth: Noisy depth image (H, W), metres, 0 = no depth.
        labels: Exact per-pixel labels (H, W): -1 nothing, 0 the table, i + 1 object i.
        table_height: Height of the table top, metres.
        seed: The seed it was drawn with.
    """

    robot: str
    names: tuple[str, ...]
    poses: np.ndarray
    meshes: tuple[Any, ...]
    camera: Camera
    depth: np.ndarray
    labels: np.ndarray
    table_height: float
    seed: int

    def mask(self, i: int) -> np.ndarray:
        """Pixels of object ``i`` (H, W), bool."""
        return self.labels == i + 1


def head_camera(robot: Any, width: int = 640, height: int = 480) -> Camera:
    """The robot's head camera (its MJCF camera at home) as a pinhole :class:`Camera`.

    MuJoCo's camera looks along its -z with y up; the :class:`Camera` frame looks along +z with y
    down, so the rotation is flipped about x.
    """
    from symjax import robots

    r = robot if isinstance(robot, robots.Robot) else robots.load(robot)
    m = r.model()
    d = mujoco.MjData(m)
    mujoco.mj_resetDataKeyframe(m, d, m.key("home").id)
    mujoco.mj_forward(m, d)  # camera poses come from mj_camlight, not mj_kinematics
    c = m.camera(r.camera).id
    T = np.eye(4)
    u, _, vt = np.linalg.svd(d.cam_xmat[c].reshape(3, 3))  # the MJCF's 4-digit axes, made exact
    T[:3, :3] = (u @ vt) @ np.diag([1.0, -1.0, -1.0])
    T[:3, 3] = d.cam_xpos[c]
    f = 0.5 * height / np.tan(0.5 * np.radians(m.cam_fovy[c]))
    K = np.array([[f, 0.0, 0.5 * width], [0.0, f, 0.5 * height], [0.0, 0.0, 1.0]])
    return Camera.create(K, T, width, height)


def _place(rng, radii, tries: int = 400):
    """Footprint centres (k, 2) in the workspace, at least a gap of 0-3 cm apart."""
    (x0, x1), (y0, y1) = _WORKSPACE
    out: list[np.ndarray] = []
    for r in radii:
        for _ in range(tries):
            p = np.array([rng.uniform(x0, x1), rng.uniform(y0, y1)])
            gap = rng.uniform(0.0, 0.03)
            if all(
                np.linalg.norm(p - q) >= r + rq + gap for q, rq in zip(out, radii, strict=False)
            ):
                out.append(p)
                break
        else:
            return None
    return np.array(out)


def _settle(meshes, xy, yaw, height: float, seconds: float = 1.5):
    """Drops the objects on the table and returns their resting poses (k, 4, 4).

    Friction, impedance ratio and density are the grasp rollouts' (``SimulationConfig``).
    """
    from symjax.grasp.sim_config import SimulationConfig

    sim = SimulationConfig()
    spec = mujoco.MjSpec()
    spec.option.timestep = 0.002
    spec.option.impratio = sim.impratio
    friction = list(sim.geom_friction)
    spec.worldbody.add_geom(type=mujoco.mjtGeom.mjGEOM_BOX, size=[1.0, 1.0, 0.01],
                            pos=[0.65, 0.0, height - 0.01], friction=friction)  # fmt: skip
    for i, (m, p, a) in enumerate(zip(meshes, xy, yaw, strict=True)):
        spec.add_mesh(name=f"m{i}", uservert=np.asarray(m.vertices).ravel(),
                      userface=np.asarray(m.faces).ravel())  # fmt: skip
        b = spec.worldbody.add_body(name=f"o{i}", pos=[p[0], p[1], height + 0.003],
                                    quat=[np.cos(a / 2), 0.0, 0.0, np.sin(a / 2)])  # fmt: skip
        b.add_freejoint()
        b.add_geom(type=mujoco.mjtGeom.mjGEOM_MESH, meshname=f"m{i}",
                   density=sim.object_density, friction=friction)  # fmt: skip
    model = spec.compile()
    data = mujoco.MjData(model)
    for _ in range(int(seconds / model.opt.timestep)):
        mujoco.mj_step(model, data)
    if not np.all(np.isfinite(data.qpos)) or np.abs(data.qvel).max() > 0.05:
        return None  # still moving (rolling): draw again
    poses = np.tile(np.eye(4), (len(meshes), 1, 1))
    for i in range(len(meshes)):
        b = model.body(f"o{i}").id
        poses[i, :3, :3] = data.xmat[b].reshape(3, 3)
        poses[i, :3, 3] = data.xpos[b]
    return poses


def scan_scene(
    robot: str = "kth",
    n_objects: int = 3,
    seed: int = 0,
    objects: tuple[str, ...] | None = None,
    cache_dir: Any = None,
    width: int = 640,
    height: int = 480,
) -> ScanScene:
    """A seeded table scene of ``n_objects`` scans for ``robot``.

    Args:
        robot: ``"kth"`` or ``"uji"``.
        n_objects: 1 to 6 objects.
        seed: Seed of the choice, placement, settling and noise.
        objects: Scan names to draw from (default :data:`SCENE_OBJECTS`).
        cache_dir: Cache of the preprocessed scans (see :func:`symjax.datasets.load_object`);
            default the benchmark's cache folder.
        width, height: Image size, pixels.

    Raises:
        InvalidInputError: ``n_objects`` outside 1-6 or more than the pool.
        UnknownNameError: An unknown robot or scan.
        SimulationError: No resting arrangement in 10 draws.
    """
    from symjax import robots
    from symjax.datasets.collection import default_cache_dir
    from symjax.datasets.objects import load_object

    cache_dir = default_cache_dir() if cache_dir is None else cache_dir
    pool = tuple(objects) if objects is not None else SCENE_OBJECTS
    if not isinstance(n_objects, int) or not 1 <= n_objects <= min(6, len(pool)):
        raise InvalidInputError(
            f"n_objects must be an int in [1, {min(6, len(pool))}], got {n_objects!r}"
        )
    r = robots.load(robot)
    h = r.table_height()
    rng = np.random.default_rng(seed)
    for _attempt in range(10):
        names = tuple(str(x) for x in rng.choice(pool, n_objects, replace=False))
        models = [load_object(n, cache_dir=cache_dir) for n in names]
        radii = [float(np.linalg.norm(np.asarray(o.mesh.vertices)[:, :2], axis=1).max())
                 for o in models]  # fmt: skip
        xy = _place(rng, radii)
        if xy is None:
            continue
        poses = _settle([o.mesh for o in models], xy, rng.uniform(-np.pi, np.pi, n_objects), h)
        if poses is not None and np.all(poses[:, 2, 3] > h - 0.01):
            break
    else:
        raise SimulationError(f"no resting arrangement of {n_objects} objects in 10 draws")
    meshes = []
    for o, T in zip(models, poses, strict=True):
        m = o.mesh.copy()
        m.apply_transform(T)
        meshes.append(m)
    cam = head_camera(r, width, height)
    depth, labels = _render(meshes, cam, h, rng)
    return ScanScene(r.name, names, poses, tuple(meshes), cam, depth, labels, h, int(seed))


def _render(meshes, cam: Camera, height: float, rng) -> tuple[np.ndarray, np.ndarray]:
    """Noisy depth (H, W) and exact labels (H, W) of world-frame meshes on the table."""
    from symjax.datasets.raycast import render_depth, scene_model
    from symjax.datasets.render import hit_normals
    from symjax.datasets.stereo import StereoHead, StereoNoise, simulate_stereo

    depth, geom = render_depth(scene_model(meshes=list(meshes), table_height=height), cam)
    labels = np.where(depth > 0, geom, -1).astype(np.int32)  # geom 0 is the table
    normals = hit_normals(depth, cam, [(m, labels == i + 1) for i, m in enumerate(meshes)])
    noisy, _ = simulate_stereo(depth, labels > 0, normals, cam, StereoNoise(),
                               StereoHead().baseline, rng)  # fmt: skip
    return noisy, labels


def rearranged(scene: ScanScene, keep: Any, poses: Any, seed: int = 0) -> ScanScene:
    """The scene after the robot acted: only objects ``keep``, at ``poses``, seen again.

    Args:
        scene: The scene before.
        keep: Indices of the objects still on the table, in the order of the new labels.
        poses: Their new object-to-world transforms, shape (len(keep), 4, 4).
        seed: Seed of the new image's stereo noise.

    Returns:
        A :class:`ScanScene` of the kept objects, re-rendered from the same camera.

    Raises:
        InvalidInputError: Poses not one finite (4, 4) per kept object, or a bad index.
    """
    keep = [int(i) for i in keep]
    poses = np.asarray(poses, float)
    if poses.shape != (len(keep), 4, 4) or not np.all(np.isfinite(poses)):
        raise InvalidInputError(
            f"poses must be finite ({len(keep)}, 4, 4) transforms, one per kept object; got"
            f" shape {poses.shape}"
        )
    if any(not 0 <= i < len(scene.names) for i in keep) or len(set(keep)) != len(keep):
        raise InvalidInputError(
            f"keep must be distinct object indices in [0, {len(scene.names)}), got {keep}"
        )
    meshes = []
    for i, T in zip(keep, poses, strict=True):
        m = scene.meshes[i].copy()
        m.apply_transform(T @ np.linalg.inv(scene.poses[i]))
        meshes.append(m)
    rng = np.random.default_rng(seed)
    depth, labels = _render(meshes, scene.camera, scene.table_height, rng)
    return dataclasses.replace(
        scene,
        names=tuple(scene.names[i] for i in keep),
        poses=poses,
        meshes=tuple(meshes),
        depth=depth,
        labels=labels,
        seed=int(seed),
    )
