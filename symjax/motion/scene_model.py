"""The compiled variant of a planning scene: its MuJoCo model, geom groups and the helpers that
build it and classify its contacts.
"""

from __future__ import annotations

import dataclasses
from typing import Any

import mujoco
import numpy as np

from symjax.errors import EmptyInputError, InvalidInputError, ShapeError

__all__ = ["CARRIED", "SceneModel", "add_hulls", "classify", "has_geom", "hull_list", "mat_to_quat"]

CARRIED = "carried"  # the body (and geom prefix) of an attached object under the hand


@dataclasses.dataclass(eq=False)
class SceneModel:
    """One compiled variant of a :class:`PlanningScene` and its geom groups.

    Attributes:
        model: The compiled model (arm, hand, table, objects; the attached object under the
            hand).
        data: Scratch data for collision checks.
        arm_geoms, hand_geoms: Geom ids of the arm links and of the hand, (k,) int.
        carried_geoms: Geoms of the attached object, (k,) int (empty when nothing is attached).
        fixed_geoms: Table, floor and pedestal, (k,) int.
        object_geoms: Per object name, its geom ids.
        robot_mask: Per geom: arm, hand or carried, (ngeom,) bool.
        mocap: Per object name, its mocap index.
        carried_body: Body id of the attachment body, or -1.
        tcp_site: Site id of the TCP.
    """

    model: mujoco.MjModel
    data: mujoco.MjData
    arm_geoms: np.ndarray
    hand_geoms: np.ndarray
    carried_geoms: np.ndarray
    fixed_geoms: np.ndarray
    object_geoms: dict[str, np.ndarray]
    robot_mask: np.ndarray
    mocap: dict[str, int]
    carried_body: int
    tcp_site: int


def hull_list(hulls: Any) -> list[tuple[np.ndarray, np.ndarray]]:
    from symjax.decompose import Decomposition

    if isinstance(hulls, Decomposition):
        hulls = hulls.hulls
    if not isinstance(hulls, (list, tuple)) or not hulls:
        raise EmptyInputError(
            "an object needs a Decomposition or a non-empty list of (vertices, faces) hulls"
        )
    out = []
    for v, f in hulls:
        v, f = np.asarray(v, np.float64), np.asarray(f)
        if v.ndim != 2 or v.shape[1] != 3 or len(v) < 4 or f.ndim != 2 or f.shape[1] != 3:
            raise ShapeError(f"a hull needs vertices (V>=4, 3) and faces (F, 3), got {v.shape}")
        if not np.all(np.isfinite(v)):
            raise InvalidInputError("hull vertices contain NaN or inf")
        out.append((v, f.astype(np.int64)))
    return out


def _mask(n: int, ids) -> np.ndarray:
    out = np.zeros(n, bool)
    out[np.asarray(ids, int)] = True
    return out


def classify(sm: SceneModel, g1, g2, allow) -> np.ndarray:
    n = len(sm.robot_mask)
    bad = sm.robot_mask[g1] | sm.robot_mask[g2]
    hand, carried = _mask(n, sm.hand_geoms), _mask(n, sm.carried_geoms)
    # The held object touches the fingers by design.
    bad &= ~((carried[g1] & hand[g2]) | (carried[g2] & hand[g1]))
    parts = {"hand": hand, "carried": carried, "robot": sm.robot_mask}
    for part, other in allow:
        if other == "table":
            env = _mask(n, sm.fixed_geoms[:1])
        elif other in sm.object_geoms:
            env = _mask(n, sm.object_geoms[other])
        else:
            continue
        mover = parts[part]
        bad &= ~((mover[g1] & env[g2]) | (mover[g2] & env[g1]))
    return bad


def has_geom(m: mujoco.MjModel, name: str) -> bool:
    return mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, name) >= 0


def mat_to_quat(R: np.ndarray) -> np.ndarray:
    q = np.zeros(4)
    mujoco.mju_mat2Quat(q, np.ascontiguousarray(R, np.float64).ravel())
    return q


def add_hulls(spec, body, prefix: str, hulls, rgba) -> None:
    for i, (v, f) in enumerate(hulls):
        mesh = f"{prefix}/hull{i}"
        spec.add_mesh(name=mesh, uservert=v.ravel(), userface=f.ravel())
        body.add_geom(name=mesh, type=mujoco.mjtGeom.mjGEOM_MESH, meshname=mesh,
                      rgba=rgba, density=0.0)  # fmt: skip
