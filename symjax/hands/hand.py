"""Robot hands: the MJCF models in ``assets/hands`` and what a grasp simulation needs to drive them.

Every hand follows the same conventions so that grasp candidates are hand-agnostic:

* the model's root body is the hand base, mounted on the arm flange;
* a site named ``tcp`` marks the grasp centre; its +z axis is the approach direction (out of
  the palm) and its +x axis the closing axis (from the thumb to the opposing fingers, or from
  one jaw to the other);
* keyframes ``home``, ``open`` and ``pinch`` are the pre-shapes, in that order (paper IV-A:
  "as a hand pre-shape, we defined a pinch grasp for each hand").
"""

from __future__ import annotations

import dataclasses
from typing import Any

import mujoco
import numpy as np

from symjax._pytree import pytree_dataclass, static_field
from symjax.array_types import ArrayLike
from symjax.errors import FileFormatError, InvalidInputError, MissingFileError, unknown_name
from symjax.resources import asset_dir

__all__ = ["as_hand", "HAND_NAMES", "PRESHAPES", "Hand", "load", "probe_points"]

PRESHAPES = ("home", "open", "pinch")
"""Pre-shape keyframe names; a candidate's ``preshape`` indexes this tuple."""


@dataclasses.dataclass(frozen=True)
class _HandInfo:
    """What the MJCF cannot say: which geoms form each finger and how the hand closes."""

    fingers: tuple[tuple[str, tuple[str, ...]], ...]
    close_ctrl: dict[str, float]
    couplings: tuple[tuple[str, str, float], ...]


# close_ctrl: the position targets that close the hand; actuators not listed keep their
# pre-shape target (the SDH knuckle, the Barrett spread). Targets lie past contact on purpose:
# the force limits, not the targets, set the grip. couplings: (joint, driver, ratio).
_INFO: dict[str, _HandInfo] = {
    "sdh": _HandInfo(
        fingers=(
            ("f1", ("f1_proximal", "f1_distal")),
            ("f2", ("f2_proximal", "f2_distal")),
            ("thumb", ("thumb_proximal", "thumb_distal")),
        ),
        close_ctrl={
            "f1_proximal": 1.2,
            "f1_distal": 1.2,
            "f2_proximal": 1.2,
            "f2_distal": 1.2,
            "thumb_proximal": 1.2,
            "thumb_distal": 1.2,
        },
        couplings=(("f2_base", "f1_base", 1.0),),
    ),
    "barrett": _HandInfo(
        fingers=(
            ("f1", ("f1_proximal", "f1_distal")),
            ("f2", ("f2_proximal", "f2_distal")),
            ("f3", ("f3_proximal", "f3_distal")),
        ),
        close_ctrl={"f1": 2.4435, "f2": 2.4435, "f3": 2.4435},
        couplings=(
            ("f2_spread", "f1_spread", 1.0),
            ("f1_distal", "f1_proximal", 48.0 / 140.0),
            ("f2_distal", "f2_proximal", 48.0 / 140.0),
            ("f3_distal", "f3_proximal", 48.0 / 140.0),
        ),
    ),
    "parallel_jaw": _HandInfo(
        fingers=(("left", ("left_pad",)), ("right", ("right_pad",))),
        close_ctrl={"jaw": 0.0},
        couplings=(("right", "left", 1.0),),
    ),
}
HAND_NAMES = tuple(_INFO)


@pytree_dataclass
class Hand:
    """A hand model plus the arrays a batched grasp simulation indexes.

    Array fields are pytree leaves (they can be passed through ``jax.jit``); names are static.
    ``P`` is the number of pre-shapes (``len(PRESHAPES)``), ``nq``/``nu`` the hand's joint and
    actuator counts.

    Attributes:
        preshape_qpos: Joint angles of each pre-shape, shape (P, nq), radians or metres.
        preshape_ctrl: Actuator targets holding each pre-shape, shape (P, nu).
        close_ctrl: Actuator targets that close the hand, shape (nu,).
        close_mask: Which actuators closing changes, shape (nu,), bool; the others keep the
            pre-shape target (:meth:`closed_ctrl`).
        ctrl_range: Actuator control ranges, shape (nu, 2).
        tcp_pos: TCP position in the hand base frame, shape (3,), metres.
        tcp_quat: TCP orientation in the hand base frame, (w, x, y, z), shape (4,).
        name: Hand name (``"sdh"``, ``"barrett"``, ``"parallel_jaw"``).
        xml_path: The hand's MJCF file.
        base_body: Name of the root body (mounted on the flange).
        tcp_site: Name of the TCP site.
        joint_names: Hand joints in qpos order.
        actuator_names: Actuators in ctrl order.
        finger_names: One name per finger.
        finger_geoms: Per finger, the names of its link geoms (contact checks).
        palm_geoms: Geoms of the base body.
        couplings: ``(joint, driver, ratio)``: ``q[joint] = ratio * q[driver]`` by equality.
        preshape_names: Names of the pre-shapes, the keyframe names.
    """

    preshape_qpos: Any
    preshape_ctrl: Any
    close_ctrl: Any
    close_mask: Any
    ctrl_range: Any
    tcp_pos: Any
    tcp_quat: Any
    name: str = static_field()
    xml_path: str = static_field()
    base_body: str = static_field()
    tcp_site: str = static_field()
    joint_names: tuple[str, ...] = static_field()
    actuator_names: tuple[str, ...] = static_field()
    finger_names: tuple[str, ...] = static_field()
    finger_geoms: tuple[tuple[str, ...], ...] = static_field()
    palm_geoms: tuple[str, ...] = static_field()
    couplings: tuple[tuple[str, str, float], ...] = static_field()
    preshape_names: tuple[str, ...] = static_field(default=PRESHAPES)

    @property
    def nq(self) -> int:
        return len(self.joint_names)

    @property
    def nu(self) -> int:
        return len(self.actuator_names)

    def spec(self) -> mujoco.MjSpec:
        """A fresh, editable :class:`mujoco.MjSpec` of the hand alone (base fixed at the origin)."""
        return mujoco.MjSpec.from_file(self.xml_path)

    def model(self) -> mujoco.MjModel:
        """The compiled hand-alone model."""
        return mujoco.MjModel.from_xml_path(self.xml_path)

    def preshape_index(self, name: str) -> int:
        """Index of the pre-shape ``name`` in :attr:`preshape_names`."""
        if name not in self.preshape_names:
            raise unknown_name("pre-shape", name, self.preshape_names)
        return self.preshape_names.index(name)

    def closed_ctrl(self, preshape: ArrayLike) -> ArrayLike:
        """Actuator targets that close the hand from pre-shape ``preshape`` (index), shape (nu,).

        Works on numpy and inside ``jax.jit`` (``preshape`` may be traced).
        """
        import jax.numpy as jnp

        return jnp.where(self.close_mask, self.close_ctrl, self.preshape_ctrl[preshape])


def as_hand(hand: Hand | str) -> Hand:
    """A :class:`Hand`, or the hand of that name (see :func:`load`).

    Raises:
        UnknownNameError: An unknown name.
        InvalidInputError: Neither a Hand nor a name.
    """
    if isinstance(hand, Hand):
        return hand
    if isinstance(hand, str):
        return load(hand)
    raise InvalidInputError(
        f"hand must be a symjax.hands.Hand or one of {', '.join(HAND_NAMES)}, got"
        f" {type(hand).__name__}"
    )


def load(name: str) -> Hand:
    """Loads a hand by name.

    Args:
        name: One of :data:`HAND_NAMES` (``"sdh"``, ``"barrett"``, ``"parallel_jaw"``).

    Returns:
        The :class:`Hand`.

    Raises:
        UnknownNameError: ``name`` is not a known hand (the message lists the valid names).
        MissingFileError: The MJCF file is missing.
        FileFormatError: The MJCF lacks the conventions above (TCP site, pre-shape keyframes).
    """
    if not isinstance(name, str) or name not in _INFO:
        raise unknown_name("hand", name, HAND_NAMES)
    info = _INFO[name]
    path = asset_dir() / "hands" / name / f"{name}.xml"
    if not path.is_file():
        raise MissingFileError(f"hand model {path} is missing")
    try:
        m = mujoco.MjModel.from_xml_path(str(path))
    except ValueError as e:
        raise FileFormatError(f"cannot load hand model {path}: {e}") from e

    def names(objtype, count):
        return tuple(mujoco.mj_id2name(m, objtype, i) for i in range(count))

    joints = names(mujoco.mjtObj.mjOBJ_JOINT, m.njnt)
    actuators = names(mujoco.mjtObj.mjOBJ_ACTUATOR, m.nu)
    keys = names(mujoco.mjtObj.mjOBJ_KEY, m.nkey)
    if tuple(keys[: len(PRESHAPES)]) != PRESHAPES:
        raise FileFormatError(f"{path}: keyframes must start with {PRESHAPES}, got {keys}")
    tcp = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_SITE, "tcp")
    if tcp < 0:
        raise FileFormatError(f"{path}: no site named 'tcp'")
    if m.nq != m.njnt:
        raise FileFormatError(f"{path}: hand joints must be hinges or slides")
    unknown = set(info.close_ctrl) - set(actuators)
    if unknown:
        raise FileFormatError(f"{path}: no actuators {sorted(unknown)}")
    geoms = set(names(mujoco.mjtObj.mjOBJ_GEOM, m.ngeom))
    for _, gs in info.fingers:
        for g in gs:
            if g not in geoms:
                raise FileFormatError(f"{path}: no finger geom {g!r}")
    close = np.zeros(m.nu)
    mask = np.zeros(m.nu, dtype=bool)
    for a, v in info.close_ctrl.items():
        close[actuators.index(a)] = v
        mask[actuators.index(a)] = True
    P = len(PRESHAPES)
    base = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_BODY, 1)
    palm = tuple(
        mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_GEOM, g)
        for g in range(m.ngeom)
        if m.geom_bodyid[g] == 1
    )
    return Hand(
        preshape_qpos=np.array(m.key_qpos[:P], dtype=np.float64),
        preshape_ctrl=np.array(m.key_ctrl[:P], dtype=np.float64),
        close_ctrl=close,
        close_mask=mask,
        ctrl_range=np.array(m.actuator_ctrlrange, dtype=np.float64),
        tcp_pos=np.array(m.site_pos[tcp], dtype=np.float64),
        tcp_quat=np.array(m.site_quat[tcp], dtype=np.float64),
        name=name,
        xml_path=str(path),
        base_body=base,
        tcp_site="tcp",
        joint_names=joints,
        actuator_names=actuators,
        finger_names=tuple(f for f, _ in info.fingers),
        finger_geoms=tuple(gs for _, gs in info.fingers),
        palm_geoms=palm,
        couplings=info.couplings,
    )


def probe_points(hand: Hand, preshape: int | str = "pinch") -> np.ndarray:
    """Points on the hand's surface hull in the TCP frame at a pre-shape, shape (K, 3), metres.

    Box corners, capsule and cylinder end caps and geom centres: a cheap stand-in for the hand's
    volume, used to drop grasp candidates whose start pose puts the hand inside the table or
    the object.
    """
    if isinstance(preshape, str):
        preshape = hand.preshape_index(preshape)
    if not 0 <= int(preshape) < len(hand.preshape_names):
        raise InvalidInputError(f"pre-shape index {preshape} out of range")
    m = hand.model()
    d = mujoco.MjData(m)
    d.qpos[:] = np.asarray(hand.preshape_qpos)[int(preshape)]
    mujoco.mj_kinematics(m, d)
    pts = []
    for g in range(m.ngeom):
        c, R, s = d.geom_xpos[g], d.geom_xmat[g].reshape(3, 3), m.geom_size[g]
        pts.append(c)
        t = int(m.geom_type[g])
        if t == int(mujoco.mjtGeom.mjGEOM_BOX):
            signs = np.array(np.meshgrid([-1, 1], [-1, 1], [-1, 1])).reshape(3, -1).T
            pts.extend(c + (signs * s) @ R.T)
        elif t in (int(mujoco.mjtGeom.mjGEOM_CAPSULE), int(mujoco.mjtGeom.mjGEOM_CYLINDER)):
            reach = s[1] + (s[0] if t == int(mujoco.mjtGeom.mjGEOM_CAPSULE) else 0.0)
            pts.extend([c + R[:, 2] * reach, c - R[:, 2] * reach])
    tcp = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_SITE, hand.tcp_site)
    Rt, pt = d.site_xmat[tcp].reshape(3, 3), d.site_xpos[tcp]
    return (np.asarray(pts) - pt) @ Rt
