"""The grasp scene, built with :class:`mujoco.MjSpec`: a table plane, the object's convex hulls
on a free joint (body origin at its centre of mass, welded in place during the approach) and the
hand on a floating base: three world slides driven by force-limited velocity servos and three
hinges (intrinsic z-y-x Euler angles) held by position servos. Each candidate only differs in
its initial ``qpos`` and its control sequence, so one model serves the whole batch. The hand's
bodies are gravity-compensated.
"""

from __future__ import annotations

import dataclasses
import functools
from typing import Any

import mujoco
import numpy as np

from symjax.errors import (
    EmptyInputError,
    InvalidInputError,
    SimulationError,
    config_or_default,
)
from symjax.grasp.sim_config import SimulationConfig

__all__ = ["GraspScene", "build_scene", "contact_model"]


@dataclasses.dataclass(frozen=True, eq=False)
class GraspScene:
    """A compiled grasp scene and the index tables the rollouts need.

    Attributes:
        model: The compiled :class:`mujoco.MjModel`.
        hand: The :class:`symjax.hands.Hand`.
        config: The :class:`SimulationConfig`.
        com: Object centre of mass at rest, shape (3,), metres.
        radius: Largest distance from the centre of mass to a hull vertex, metres (the torque
            scale of the quality test).
        mass: Object mass, kg.
        table_height: Height of the table plane, metres.
        qadr_base: qpos addresses of the slides x, y, z and hinges z, y, x, shape (6,).
        qadr_hand: qpos addresses of the hand joints (``hand.joint_names`` order).
        qadr_object: qpos address of the object's free joint (position then quaternion).
        dadr_object: dof address of the object's free joint (linear, world frame, first).
        act_slide, act_hinge, act_hand: Actuator indices.
        weld: Index of the object's weld equality.
        geom_finger: Per geom: finger index, ``F`` for the palm, -1 if not the hand, (ngeom,).
        geom_object: Per geom: part of the object, (ngeom,), bool.
        geom_table: Per geom: the table, (ngeom,), bool.
    """

    model: mujoco.MjModel
    hand: Any
    config: SimulationConfig
    com: np.ndarray
    radius: float
    mass: float
    table_height: float
    qadr_base: np.ndarray
    qadr_hand: np.ndarray
    qadr_object: int
    dadr_object: int
    act_slide: np.ndarray
    act_hinge: np.ndarray
    act_hand: np.ndarray
    weld: int
    geom_finger: np.ndarray
    geom_object: np.ndarray
    geom_table: np.ndarray

    @functools.cached_property
    def _mjx(self):
        from mujoco import mjx

        return mjx.put_model(self.model, impl="jax")


def _hull_list(obj: Any) -> list[tuple[np.ndarray, np.ndarray]]:
    from symjax.decompose import Decomposition, decompose

    if isinstance(obj, Decomposition):
        return [(np.asarray(v, float), np.asarray(f, int)) for v, f in obj.hulls]
    if hasattr(obj, "vertices") and hasattr(obj, "faces"):  # a trimesh.Trimesh
        return _hull_list(decompose(obj))
    if (
        isinstance(obj, tuple)
        and len(obj) == 2
        and isinstance(obj[0], np.ndarray)
        and np.asarray(obj[1]).dtype.kind in "iu"
    ):
        return _hull_list(decompose(obj))
    if not isinstance(obj, (list, tuple)) or not obj:
        raise EmptyInputError("object must be a Decomposition, a list of hulls or a mesh")
    return [(np.asarray(v, float), np.asarray(f, int)) for v, f in obj]


def _table_height(table: Any, hulls) -> float:
    if table is None:
        return float(min(v[:, 2].min() for v, _ in hulls))
    if isinstance(table, (int, float)):
        return float(table)
    n, off = np.asarray(table.normal, float), float(table.offset)
    if abs(n[2]) < 0.999:
        raise InvalidInputError("the grasp simulation needs a horizontal table (normal along z)")
    return float(-off / n[2])


def build_scene(
    obj: Any,
    hand: Any,
    config: SimulationConfig | None = None,
    table: Any = None,
    obstacles: Any = None,
) -> GraspScene:
    """Builds the grasp scene for one object and hand.

    Args:
        obj: A :class:`symjax.decompose.Decomposition`, a list of ``(vertices, faces)`` convex
            hulls, or a mesh (``trimesh.Trimesh`` or ``(vertices, faces)``, decomposed with
            coacd), world frame, metres.
        hand: A :class:`symjax.hands.Hand`.
        config: :class:`SimulationConfig`.
        table: Table height (metres), a horizontal :class:`symjax.table.TablePlane`, or None
            (the object's lowest vertex).
        obstacles: The other objects on the table, fixed: a list of ``(vertices, faces)``
            convex hulls (or of Decompositions), world frame, metres. A candidate whose hand
            starts inside one fails; one that runs into one is stopped by it.

    Returns:
        The :class:`GraspScene`.
    """
    from symjax.decompose import mass_properties
    from symjax.hands import as_hand

    hand = as_hand(hand)
    cfg = config_or_default(config, SimulationConfig)
    hulls = _hull_list(obj)
    height = _table_height(table, hulls)
    # Body origin at the centre of mass: the free joint's position is then the object's.
    parts = [mass_properties(v, f, cfg.object_density) for v, f in hulls]
    mass = sum(p[0] for p in parts)
    com = sum(p[0] * p[1] for p in parts) / mass
    radius = float(max(np.linalg.norm(v - com, axis=1).max() for v, _ in hulls))

    spec = scene_spec(hulls, com, hand, cfg, height, obstacle_hulls(obstacles))
    try:
        m = spec.compile()
    except ValueError as e:
        raise SimulationError(f"cannot compile the grasp scene: {e}") from e
    obj_body = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, "object")
    return GraspScene(
        model=m,
        hand=hand,
        config=cfg,
        com=np.asarray(com, float),
        radius=radius,
        mass=float(m.body_mass[obj_body]),
        table_height=height,
        **index_tables(m, hand),
    )


def obstacle_hulls(obstacles: Any) -> list[tuple[np.ndarray, np.ndarray]]:
    """Obstacle hulls as one flat list of ``(vertices (V, 3), faces (F, 3))``.

    Raises:
        InvalidInputError: Not a list of hulls or Decompositions, or a hull that is not
            finite vertices (V >= 4, 3) with faces.
    """
    from symjax.decompose import Decomposition

    if obstacles is None:
        return []
    if isinstance(obstacles, Decomposition) or not isinstance(obstacles, (list, tuple)):
        raise InvalidInputError(
            "obstacles must be a list of (vertices, faces) hulls or of Decompositions, got"
            f" {type(obstacles).__name__}"
        )
    out = []
    for o in obstacles:
        if not isinstance(o, Decomposition) and not (isinstance(o, (tuple, list)) and len(o) == 2):
            raise InvalidInputError(
                "obstacles must be a list of (vertices, faces) hulls or of Decompositions; an"
                f" item is a {type(o).__name__} (one hull goes in a list: [(vertices, faces)])"
            )
        for v, f in o.hulls if isinstance(o, Decomposition) else [o]:
            v, f = np.asarray(v, float), np.asarray(f)
            if v.ndim != 2 or v.shape[1] != 3 or len(v) < 4 or not np.all(np.isfinite(v)):
                raise InvalidInputError(
                    f"an obstacle hull needs finite vertices (V >= 4, 3), got {v.shape}"
                )
            if f.ndim != 2 or f.shape[1] != 3 or f.dtype.kind not in "iu":
                raise InvalidInputError(f"an obstacle hull needs int faces (F, 3), got {f.shape}")
            out.append((v, f.astype(int)))
    return out


def scene_spec(
    hulls, com: np.ndarray, hand: Any, config: SimulationConfig, height: float, obstacles=()
):
    """The :class:`mujoco.MjSpec` of a grasp scene (see the module docstring).

    Args:
        hulls: ``(vertices (V_i, 3), faces (F_i, 3))`` convex hulls, world frame, metres.
        com: (3,) the object's centre of mass, metres (its body origin).
        hand: The :class:`symjax.hands.Hand`.
        config: :class:`SimulationConfig`.
        height: Table height, metres.
        obstacles: Fixed hulls of the other objects, world frame (see :func:`obstacle_hulls`).
    """
    from symjax.decompose import object_spec

    spec = mujoco.MjSpec()
    spec.modelname = f"grasp_{hand.name}"
    o = spec.option
    o.timestep = config.timestep
    o.iterations = config.iterations
    o.ls_iterations = config.ls_iterations
    o.integrator = mujoco.mjtIntegrator.mjINT_IMPLICITFAST
    if config.mjx_max_contacts is not None:
        spec.add_numeric(name="max_contact_points", data=[config.mjx_max_contacts])
    if config.mjx_max_pairs is not None:
        spec.add_numeric(name="max_geom_pairs", data=[config.mjx_max_pairs])
    o.gravity = [0.0, 0.0, -9.81]
    spec.worldbody.add_geom(
        name="table",
        type=mujoco.mjtGeom.mjGEOM_PLANE,
        size=[0.0, 0.0, 1.0],
        pos=[0.0, 0.0, height],
        friction=list(config.geom_friction),
        condim=3,
    )
    for i, (v, f) in enumerate(obstacles):
        spec.add_mesh(name=f"obstacle{i}", uservert=v.ravel(), userface=f.ravel())
        spec.worldbody.add_geom(
            name=f"obstacle{i}", type=mujoco.mjtGeom.mjGEOM_MESH, meshname=f"obstacle{i}",
            friction=list(config.geom_friction), condim=3,
        )  # fmt: skip
    object_spec(
        [(v - com, f) for v, f in hulls],
        name="object",
        pos=com,
        mass=config.object_mass,
        density=config.object_density,
        friction=config.geom_friction,
        spec=spec,
    )
    weld = spec.add_equality(
        name="object_hold",
        type=mujoco.mjtEq.mjEQ_WELD,
        objtype=mujoco.mjtObj.mjOBJ_BODY,
        name1="object",
    )
    weld.solref = [0.005, 1.0]

    hs = hand.spec()
    hs.option.timestep = config.timestep  # the parent's options win; matching avoids a warning
    for k in list(hs.keys):
        hs.delete(k)
    frame = spec.worldbody.add_frame()
    spec.attach(hs, prefix="hand/", frame=frame)
    base = spec.body("hand/" + hand.base_body)
    for ax, vec in zip("xyz", np.eye(3), strict=True):
        # Unlimited explicitly: a base body with a childclass (the parallel jaw's) would
        # otherwise hand its finger joints' range to these joints.
        base.add_joint(
            name=f"base_{ax}", type=mujoco.mjtJoint.mjJNT_SLIDE, axis=vec, armature=0.01,
            damping=1.0, limited=mujoco.mjtLimited.mjLIMITED_FALSE,
        )  # fmt: skip
    for ax, vec in (("rz", (0, 0, 1)), ("ry", (0, 1, 0)), ("rx", (1, 0, 0))):
        base.add_joint(
            name=f"base_{ax}", type=mujoco.mjtJoint.mjJNT_HINGE, axis=vec, armature=0.02,
            damping=0.5, limited=mujoco.mjtLimited.mjLIMITED_FALSE,
        )  # fmt: skip
    for b in spec.bodies:
        if b.name.startswith("hand/"):
            b.gravcomp = 1.0
    for g in spec.geoms:
        # MJX has no margin for box-mesh pairs; zero it everywhere so both backends agree.
        g.margin = 0.0
    contact_model(spec, config, "hand/")
    for ax in "xyz":
        a = spec.add_actuator(name=f"base_v{ax}", target=f"base_{ax}")
        a.trntype = mujoco.mjtTrn.mjTRN_JOINT
        a.set_to_velocity(kv=config.base_kv)
        a.forcelimited = True
        a.forcerange = [-config.base_force, config.base_force]
    for ax in ("rz", "ry", "rx"):
        a = spec.add_actuator(name=f"base_p{ax}", target=f"base_{ax}")
        a.trntype = mujoco.mjtTrn.mjTRN_JOINT
        a.set_to_position(kp=config.base_kp_rot, dampratio=1.0)
    return spec


def contact_model(spec: mujoco.MjSpec, config: SimulationConfig, hand_prefix: str) -> None:
    """The rollouts' contacts on a spec: the friction cone, the impedance ratio and torsional
    friction on the geoms whose names start with ``hand_prefix`` (also the arm replay's)."""
    spec.option.cone = (
        mujoco.mjtCone.mjCONE_ELLIPTIC
        if config.cone == "elliptic"
        else mujoco.mjtCone.mjCONE_PYRAMIDAL
    )
    spec.option.impratio = config.impratio
    if config.finger_torsion <= 0:
        return
    for g in spec.geoms:
        if g.name.startswith(hand_prefix):
            # Soft finger pads: torsional friction keeps a pinched object from pivoting about
            # the line through two point contacts.
            g.condim = 4
            g.friction = [g.friction[0], config.finger_torsion, g.friction[2]]


def index_tables(m: mujoco.MjModel, hand: Any) -> dict[str, Any]:
    """The qpos, dof, actuator, equality and geom index tables of a compiled grasp scene.

    Returns:
        The :class:`GraspScene` fields ``qadr_*``, ``dadr_object``, ``act_*``, ``weld`` and
        ``geom_*``.
    """

    def jid(name):
        return int(m.jnt_qposadr[mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, name)])

    def aid(name):
        return mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_ACTUATOR, name)

    def gid(name):
        return mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, name)

    geom_finger = np.full(m.ngeom, -1, dtype=np.int32)
    base_id = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, "hand/" + hand.base_body)
    for g in range(m.ngeom):
        b = int(m.geom_bodyid[g])
        while b > 0 and b != base_id:
            b = int(m.body_parentid[b])
        if b == base_id:
            geom_finger[g] = len(hand.finger_names)  # palm unless a finger claims it below
    for i, gs in enumerate(hand.finger_geoms):
        for g in gs:
            geom_finger[gid("hand/" + g)] = i
    obj_body = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, "object")
    return dict(
        qadr_base=np.array([jid(f"base_{a}") for a in ("x", "y", "z", "rz", "ry", "rx")]),
        qadr_hand=np.array([jid("hand/" + j) for j in hand.joint_names]),
        qadr_object=jid("object"),
        dadr_object=int(m.jnt_dofadr[mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, "object")]),
        act_slide=np.array([aid(f"base_v{a}") for a in "xyz"]),
        act_hinge=np.array([aid(f"base_p{a}") for a in ("rz", "ry", "rx")]),
        act_hand=np.array([aid("hand/" + a) for a in hand.actuator_names]),
        weld=mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_EQUALITY, "object_hold"),
        geom_finger=geom_finger,
        geom_object=np.array([m.geom_bodyid[g] == obj_body for g in range(m.ngeom)]),
        geom_table=np.array([g == gid("table") for g in range(m.ngeom)]),
    )
