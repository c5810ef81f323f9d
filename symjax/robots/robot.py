"""The paper's two robots (Section III): arm + hand + table + head camera as MJCF scenes.

* ``"kth"``: 6-DoF Kuka arm (KR 6 R900 sixx kinematics) with the Schunk SDH.
* ``"uji"``: 7-DoF Mitsubishi PA10-7C with the Barrett BH8-282.

The scenes live in ``assets/robots/<name>/<name>.xml``; the hand is attached to the flange with
MJCF ``<attach>`` under the prefix ``hand/``. Each arm body is a Denavit-Hartenberg frame, so the
published tables in :data:`DH` give the flange pose of the ``flange`` site.
"""

from __future__ import annotations

import dataclasses

import mujoco
import numpy as np

from symjax.array_types import ArrayLike
from symjax.errors import FileFormatError, MissingFileError, ShapeError, unknown_name
from symjax.resources import asset_dir

__all__ = ["DH", "ROBOT_NAMES", "Robot", "flange_pose", "load", "robot_hand"]

DH: dict[str, dict[str, tuple[float, ...]]] = {
    # Standard DH (Craig's "distal" convention: T_i = Rz(theta_i) Tz(d_i) Tx(a_i) Rx(alpha_i)),
    # theta_i = q_i + offset_i. Metres and radians. Kuka figures from the KR 6 R900 sixx data
    # (a = 25, 455, 35; d = 400, 420, 80 mm); PA10-7C from its link offsets (d = 315, 450, 500,
    # 80 mm). The offset on joint 2 of the Kuka puts the upper arm upright at q = 0.
    "kth": {
        "a": (0.025, 0.455, 0.035, 0.0, 0.0, 0.0),
        "d": (0.400, 0.0, 0.0, 0.420, 0.0, 0.080),
        "alpha": (-np.pi / 2, 0.0, -np.pi / 2, np.pi / 2, -np.pi / 2, 0.0),
        "offset": (0.0, -np.pi / 2, 0.0, 0.0, 0.0, 0.0),
    },
    "uji": {
        "a": (0.0,) * 7,
        "d": (0.315, 0.0, 0.450, 0.0, 0.500, 0.0, 0.080),
        "alpha": (-np.pi / 2, np.pi / 2, -np.pi / 2, np.pi / 2, -np.pi / 2, np.pi / 2, 0.0),
        "offset": (0.0,) * 7,
    },
}


@dataclasses.dataclass(frozen=True)
class _RobotInfo:
    hand: str
    arm_joints: tuple[str, ...]
    arm_base: str
    home: tuple[float, ...]
    velocity_limits: tuple[float, ...]
    acceleration_limits: tuple[float, ...]
    dropoff: tuple[float, float, float]


_INFO = {
    # home: the hand pointing down, the TCP 0.394 m above the table at x 0.6 m, y 0 (solved
    # offline with mink), above the tallest scene object (0.27 m).
    "kth": _RobotInfo(
        "sdh",
        ("a1", "a2", "a3", "a4", "a5", "a6"),
        "kuka_base",
        (0.0, 0.345, -0.312, 0.0, 1.538, -1.569),
        # KR 6 R900 sixx data sheet: 360, 300, 360, 381, 388, 615 deg/s. Accelerations are not
        # published; chosen (about 1 s to full speed on the main axes).
        tuple(np.radians((360.0, 300.0, 360.0, 381.0, 388.0, 615.0))),
        (6.0, 5.0, 6.0, 8.0, 8.0, 10.0),
        (0.15, -0.6, 0.95),
    ),
    "uji": _RobotInfo(
        "barrett",
        ("s1", "s2", "s3", "e1", "e2", "w1", "w2"),
        "pa10_base",
        (-0.145, 0.227, 0.179, 1.356, -0.04, 1.562, -1.54),
        # PA10-7C data: 57 deg/s (S1, S2), 114 deg/s (S3, E1), 360 deg/s (E2, W1, W2).
        # Accelerations chosen (not published).
        tuple(np.radians((57.0, 57.0, 114.0, 114.0, 360.0, 360.0, 360.0))),
        (2.0, 2.0, 4.0, 4.0, 8.0, 8.0, 8.0),
        (0.15, 0.6, 0.95),
    ),
}
ROBOT_NAMES = tuple(_INFO)


def robot_hand(name: str) -> str:
    """The hand on a robot's flange (``"sdh"`` on ``"kth"``, ``"barrett"`` on ``"uji"``).

    Raises:
        UnknownNameError: Not one of :data:`ROBOT_NAMES`.
    """
    if name not in _INFO:
        raise unknown_name("robot", name, ROBOT_NAMES)
    return _INFO[name].hand


@dataclasses.dataclass(frozen=True)
class Robot:
    """A robot scene: arm, hand on the flange, table and head camera.

    Attributes:
        name: ``"kth"`` or ``"uji"``.
        xml_path: The scene's MJCF file.
        hand: Name of the hand on the flange (see :func:`symjax.hands.load`).
        hand_prefix: Prefix of the hand's element names in the scene (``"hand/"``).
        arm_joints: Arm joint names, base to flange; their qpos come first.
        arm_base: Name of the arm's base body.
        flange_site: Site on the flange (z out of the flange, the hand's mount frame).
        camera: Name of the head camera.
        table_geom: Name of the table geom.
        home: Arm joint angles of a pose above the table, shape (n_arm,), radians.
        dh: The published DH table of the arm (see :data:`DH`).
        velocity_limits: Joint speed limits, shape (n_arm,), rad/s.
        acceleration_limits: Joint acceleration limits, shape (n_arm,), rad/s^2.
        dropoff: Where the hand releases a picked object, beside the table: TCP position
            (3,), metres, world frame.
    """

    name: str
    xml_path: str
    hand: str
    arm_joints: tuple[str, ...]
    arm_base: str
    home: tuple[float, ...]
    dh: dict[str, tuple[float, ...]]
    velocity_limits: tuple[float, ...] = ()
    acceleration_limits: tuple[float, ...] = ()
    dropoff: tuple[float, float, float] = (0.0, 0.0, 0.0)
    hand_prefix: str = "hand/"
    flange_site: str = "flange"
    camera: str = "head_camera"
    table_geom: str = "table"

    @property
    def n_arm(self) -> int:
        return len(self.arm_joints)

    @property
    def tcp_site(self) -> str:
        """Name of the hand's TCP site in the scene."""
        return self.hand_prefix + "tcp"

    def spec(self) -> mujoco.MjSpec:
        """A fresh, editable :class:`mujoco.MjSpec` of the scene, with a ``home`` keyframe."""
        spec = mujoco.MjSpec.from_file(self.xml_path)
        m = spec.compile()
        qpos = m.qpos0.copy()
        qpos[: self.n_arm] = self.home
        ctrl = np.zeros(m.nu)
        ctrl[: self.n_arm] = self.home
        open_key = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_KEY, self.hand_prefix + "open")
        if open_key >= 0:
            qpos[self.n_arm :] = m.key_qpos[open_key, self.n_arm :]
            ctrl[self.n_arm :] = m.key_ctrl[open_key, self.n_arm :]
        spec.add_key(name="home", qpos=qpos, ctrl=ctrl)
        return spec

    def model(self) -> mujoco.MjModel:
        """The compiled scene (with the ``home`` keyframe)."""
        return self.spec().compile()

    def table_height(self, model: mujoco.MjModel | None = None) -> float:
        """Height of the table top above the floor, metres."""
        m = model if model is not None else mujoco.MjModel.from_xml_path(self.xml_path)
        d = mujoco.MjData(m)
        mujoco.mj_kinematics(m, d)
        g = m.geom(self.table_geom)
        return float(d.geom_xpos[g.id][2] + m.geom_size[g.id][2])


def load(name: str) -> Robot:
    """Loads a robot scene description by name.

    Args:
        name: ``"kth"`` (Kuka + SDH) or ``"uji"`` (PA10-7C + Barrett).

    Raises:
        UnknownNameError: ``name`` is not a known robot (the message lists the valid names).
        MissingFileError: The MJCF file is missing.
    """
    if not isinstance(name, str) or name not in _INFO:
        raise unknown_name("robot", name, ROBOT_NAMES)
    info = _INFO[name]
    path = asset_dir() / "robots" / name / f"{name}.xml"
    if not path.is_file():
        raise MissingFileError(f"robot model {path} is missing")
    return Robot(
        name=name,
        xml_path=str(path),
        hand=info.hand,
        arm_joints=info.arm_joints,
        arm_base=info.arm_base,
        home=info.home,
        dh=DH[name],
        velocity_limits=info.velocity_limits,
        acceleration_limits=info.acceleration_limits,
        dropoff=info.dropoff,
    )


def flange_pose(
    robot: Robot, q: ArrayLike, model: mujoco.MjModel | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """Forward kinematics of the arm: the flange pose relative to the arm base.

    Args:
        robot: The robot.
        q: Arm joint angles, shape (n_arm,) or (B, n_arm), radians.
        model: A compiled scene to reuse (default: compiled from ``robot``).

    Returns:
        ``(position, rotation)``: shapes (..., 3) metres and (..., 3, 3), in the frame of the
        arm's base body (the DH base frame).
    """
    q = np.asarray(q, dtype=np.float64)
    if q.shape[-1:] != (robot.n_arm,) or q.ndim > 2:
        raise ShapeError(f"q must have shape (B, {robot.n_arm}) or ({robot.n_arm},), got {q.shape}")
    m = model if model is not None else mujoco.MjModel.from_xml_path(robot.xml_path)
    d = mujoco.MjData(m)
    base = m.body(robot.arm_base).id
    site = m.site(robot.flange_site).id
    if base < 0 or site < 0:
        raise FileFormatError(f"{robot.xml_path}: missing arm base or flange site")
    pos, rot = [], []
    for qi in q.reshape(-1, robot.n_arm):
        d.qpos[: robot.n_arm] = qi
        mujoco.mj_kinematics(m, d)
        Rb = d.xmat[base].reshape(3, 3)
        pos.append(Rb.T @ (d.site_xpos[site] - d.xpos[base]))
        rot.append(Rb.T @ d.site_xmat[site].reshape(3, 3))
    shape = q.shape[:-1]
    return np.asarray(pos).reshape(*shape, 3), np.asarray(rot).reshape(*shape, 3, 3)
