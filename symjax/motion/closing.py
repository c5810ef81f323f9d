"""The fingers' closing sweep at the grasp pose, checked against the clutter.

The arm stands still while the hand closes, but the fingers sweep a volume the pre-shape does
not cover: a neighbour inside it is hit. The sweep goes from the pre-shape to the closing
targets in equal steps; a finger stops where it reaches the target object (the real finger stops
on it), the others go on. Only the clutter and the table count; the target is grasped.
"""

from __future__ import annotations

import numpy as np

from symjax.errors import ShapeError
from symjax.motion.planning_scene import PlanningScene

__all__ = ["closing_contacts"]


_ACTUATED: dict[str, tuple[tuple[int, int, int], ...]] = {}


def _actuated(hand) -> tuple[tuple[int, int, int], ...]:
    """Per actuator: (its index, the hand joint it drives, that joint's finger or -1)."""
    if hand.name in _ACTUATED:
        return _ACTUATED[hand.name]
    m = hand.model()
    out = []
    for a in range(m.nu):
        joint = m.joint(int(m.actuator_trnid[a, 0])).name
        finger = next((i for i, f in enumerate(hand.finger_names) if joint.startswith(f + "_")), -1)
        out.append((a, hand.joint_names.index(joint), finger))
    _ACTUATED[hand.name] = tuple(out)
    return _ACTUATED[hand.name]


def _hand_q(hand, pre: int, progress: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    q = np.asarray(hand.preshape_qpos, np.float64)[pre].copy()
    c0 = np.asarray(hand.preshape_ctrl, np.float64)[pre]
    c1 = np.asarray(hand.closed_ctrl(pre), np.float64)
    for a, j, f in _actuated(hand):
        s = progress[f] if f >= 0 else 1.0
        q[j] = c0[a] + s * (c1[a] - c0[a])
    names = hand.joint_names
    for joint, driver, ratio in hand.couplings:
        q[names.index(joint)] = ratio * q[names.index(driver)]
    return np.clip(q, lo, hi)


def closing_contacts(
    scene: PlanningScene, q_grasp: np.ndarray, preshape: int, steps: int = 8
) -> list[tuple[str, str, float]]:
    """Contacts of the closing fingers with anything but the target, at the grasp pose.

    Args:
        scene: The planning scene (its ``target`` is the grasped object).
        q_grasp: Full configuration at the grasp pose (nq,).
        preshape: The grasp's pre-shape index.
        steps: Samples of the sweep.

    Returns:
        ``(hand geom, other geom, distance m)`` of the first sample that hits the clutter or the
        table (closer than the scene's margin); empty when the sweep is clear.
    """
    hand, n = scene.hand, scene.robot.n_arm
    prefix = scene.robot.hand_prefix
    sm = scene.scene_model()
    q_grasp = np.asarray(q_grasp, np.float64)
    if q_grasp.shape != (sm.model.nq,):
        raise ShapeError(
            f"q_grasp must be a full configuration of shape ({sm.model.nq},), got {q_grasp.shape}"
        )
    lo, hi = sm.model.jnt_range[n : n + hand.nq].T
    fingers = [{prefix + g for g in gs} for gs in hand.finger_geoms]
    target = f"obj/{scene.target}/" if scene.target else None
    progress = np.zeros(len(fingers))
    stopped = np.zeros(len(fingers), bool)
    for k in range(1, steps + 1):
        progress[~stopped] = k / steps
        q = np.concatenate([q_grasp[:n], _hand_q(hand, preshape, progress, lo, hi)])
        hits = []
        for a, b, dist in scene.collisions(q):
            if target and (a.startswith(target) or b.startswith(target)):
                geom = a if b.startswith(target) else b
                stopped |= np.array([geom in f for f in fingers])
            elif a.startswith(prefix) or b.startswith(prefix):
                hits.append((a, b, dist))
        if hits:
            return hits
        if stopped.all():
            break
    return []
