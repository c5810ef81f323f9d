"""What ``PlanArmTrajectory`` returns: grasp poses in, time-stamped arm trajectories out."""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np

from symjax.errors import InvalidInputError, unknown_name
from symjax.geometry import as_pose

__all__ = ["SEGMENTS", "STATUSES", "ArmPlan", "GraspPose", "grasp_poses"]

STATUSES = ("ok", "unreachable", "ik_failed", "no_path", "start_in_collision")
"""``ok``: every segment planned. ``unreachable``: no IK seed reaches the pre-grasp (or drop-off)
pose within tolerance: outside the workspace. ``start_in_collision``: the pose is reachable but
the hand itself collides there with the table or an object (the candidate's start pose is bad),
or its fingers would hit a neighbour or the table while they close at the grasp.
``ik_failed``: reachable, but every arm solution collides, or a straight-line motion (approach,
lift) could not be tracked. ``no_path``: RRT-Connect found no collision-free transit."""

SEGMENTS = ("transit", "approach", "close", "lift", "transfer", "release", "return")


@dataclasses.dataclass(frozen=True)
class GraspPose:
    """A grasp for the arm: the TCP pose to start the approach from and the pose to close at.

    Attributes:
        pregrasp: TCP ``(position (3,), rotation (3, 3))`` at the start of the approach,
            world frame, metres.
        grasp: TCP pose where the hand closes (the pre-grasp moved along the approach).
        preshape: Pre-shape index into ``symjax.hands.PRESHAPES``.
        index: Index of the candidate it came from, or -1.
    """

    pregrasp: tuple[np.ndarray, np.ndarray]
    grasp: tuple[np.ndarray, np.ndarray]
    preshape: int = 1
    index: int = -1

    @staticmethod
    def from_poses(pregrasp: Any, grasp: Any, preshape: int = 1, index: int = -1) -> GraspPose:
        """From two (4, 4) matrices or ``(x, y, z, qw, qx, qy, qz)`` poses (validated)."""
        return GraspPose(as_pose(pregrasp, "pregrasp"), as_pose(grasp, "grasp"), int(preshape),
                         int(index))  # fmt: skip

    @property
    def approach(self) -> np.ndarray:
        """Unit approach direction (the TCP's z axis), (3,)."""
        return self.grasp[1][:, 2].copy()


def grasp_poses(source: Any, travel: Any = None, only_stable: bool = True) -> list[GraspPose]:
    """Grasp poses of a :class:`symjax.grasp.GraspPlan` (best first) or a ``Candidates`` batch.

    The grasp pose is the candidate's start moved ``travel`` along its approach: the rollout's
    travel to first contact for a plan (``outcomes.travel``), else the candidate's distance.

    Args:
        source: A ``GraspPlan`` or a ``Candidates`` batch.
        travel: Per-candidate travel (N,), metres, overriding the above.
        only_stable: For a plan, keep the candidates whose rollout succeeded.
    """
    from symjax.grasp.candidate_set import Candidates
    from symjax.grasp.planner import GraspPlan

    if isinstance(source, GraspPlan):
        cands, order = source.candidates, np.asarray(source.order)
        o = source.outcomes.numpy()
        keep = np.asarray(o.success, bool) if only_stable else np.ones(len(order), bool)
        travel = np.asarray(o.travel if travel is None else travel, np.float64)
    elif isinstance(source, Candidates):
        cands, order = source, np.arange(len(source))
        keep = np.ones(len(order), bool)
        travel = np.asarray(cands.distance if travel is None else travel, np.float64)
    else:
        raise InvalidInputError(
            f"grasp_poses takes a GraspPlan or a Candidates batch, got {type(source).__name__}"
        )
    R = np.asarray(cands.frames(), np.float64)
    start = np.asarray(cands.start_positions(), np.float64)
    a = np.asarray(cands.approach, np.float64)
    pre = np.asarray(cands.preshape, np.int64)
    if travel.shape != (len(order),) or not np.all(np.isfinite(travel)):
        raise InvalidInputError(f"travel must be ({len(order)},) finite metres")
    out = []
    for i in np.flatnonzero(keep):
        grasp = start[i] + travel[i] * a[i]
        out.append(GraspPose((start[i], R[i]), (grasp, R[i]), int(pre[i]), int(order[i])))
    return out


@dataclasses.dataclass(frozen=True)
class ArmPlan:
    """A planned pick (paper Section IV-B), or why there is none.

    Attributes:
        status: One of :data:`STATUSES`.
        reason: What failed and by how much (empty when ``ok``).
        robot: Robot name.
        grasp: The :class:`GraspPose` planned for.
        t: Sample times, shape (T,), seconds from the start.
        q: Arm joint angles, shape (T, n_arm), radians.
        hand: Hand command, shape (T,): 0 the grasp's pre-shape, 1 its closing targets, -1
            the ``open`` pre-shape (the release); values between blend linearly.
        segments: ``(name, first sample, end sample)`` per planned segment, in
            :data:`SEGMENTS` order; ends are exclusive.
        grasp_q: Arm angles at the grasp, (n_arm,) (NaN when not reached).
        pregrasp_error: TCP ``(metres, radians)`` from the pre-grasp pose after IK.
        grasp_error: TCP ``(metres, radians)`` from the grasp pose at the end of the approach.
        planners: Per transit segment, ``"direct"`` or ``"rrt_connect"``.
        seconds: Planning time per stage (``ik``, ``approach``, ``lift``, ``dropoff``,
            ``transit``, ``transfer``, ``return``, ``total``).
        target: The target object's name.
    """

    status: str
    reason: str
    robot: str
    grasp: GraspPose
    t: np.ndarray
    q: np.ndarray
    hand: np.ndarray
    segments: tuple[tuple[str, int, int], ...]
    grasp_q: np.ndarray
    pregrasp_error: tuple[float, float]
    grasp_error: tuple[float, float]
    planners: dict[str, str]
    seconds: dict[str, float]
    target: str

    @property
    def ok(self) -> bool:
        return self.status == "ok"

    @property
    def duration(self) -> float:
        """Length of the trajectory, seconds (0 when not planned)."""
        return float(self.t[-1]) if len(self.t) else 0.0

    def segment(self, name: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(t, q, hand)`` of one segment (see :data:`SEGMENTS`)."""
        for s, a, b in self.segments:
            if s == name:
                return self.t[a:b], self.q[a:b], self.hand[a:b]
        raise unknown_name("segment", name, [s for s, _, _ in self.segments] or SEGMENTS)

    def segment_times(self) -> dict[str, tuple[float, float]]:
        """Start and end time of each segment, seconds."""
        return {s: (float(self.t[a]), float(self.t[b - 1])) for s, a, b in self.segments}

    def summary(self) -> dict[str, Any]:
        """JSON-ready summary (no arrays)."""
        return {
            "status": self.status, "reason": self.reason, "robot": self.robot,
            "candidate": self.grasp.index, "duration_s": round(self.duration, 3),
            "pregrasp_error_mm": round(1e3 * self.pregrasp_error[0], 3),
            "grasp_error_mm": round(1e3 * self.grasp_error[0], 3),
            "planners": dict(self.planners),
            "seconds": {k: round(v, 4) for k, v in self.seconds.items()},
        }  # fmt: skip
