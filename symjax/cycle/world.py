"""The simulated table the cycle acts on: the scene's true objects, which hypothesis is which
object, ``ExecuteGrasp`` (the planned motion replayed open loop on the true shapes) and the
frame the head camera takes afterwards."""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np

__all__ = ["SimWorld"]


class SimWorld:
    """A :class:`symjax.datasets.ScanScene` as it changes while the robot clears it.

    Args:
        scene: The seeded scene (its objects, true poses and first frame).
        robot: The :class:`symjax.robots.Robot`.
        config: The cycle's :class:`~symjax.cycle.CycleConfig` (decomposition, matching,
            drop-off radius, noise seed).
    """

    def __init__(self, scene: Any, robot: Any, config: Any):
        from symjax.datasets.objects import load_object
        from symjax.decompose import decompose

        self.scene = scene
        self.robot = robot
        self.config = config
        self.names = list(scene.names)
        #: Index into the original scene of each object still on the table.
        self.alive = list(range(len(scene.names)))
        self._canonical = [load_object(n, cache_dir=config.cache_dir).mesh for n in scene.names]
        # Scans are decomposed once in their own frame (cached) and moved with their pose.
        self._hulls = [decompose(m, config.decompose) for m in self._canonical]
        self._frame = 0

    def true_mesh(self, k: int) -> Any:
        """World mesh of the object at position ``k`` of the current scene."""
        return self.scene.meshes[k]

    def true_hulls(self, k: int) -> Any:
        """World-frame :class:`~symjax.decompose.Decomposition` of object ``k`` (current)."""
        return self._hulls[self.alive[k]].transformed(self.scene.poses[k])

    def match(self, hypothesis_labels: np.ndarray, n: int) -> list[int]:
        """Per hypothesis the current object it mostly covers (-1: none covers enough)."""
        truth = self.scene.labels
        out = []
        for h in range(n):
            mine = truth[hypothesis_labels == h]
            lab = mine[mine > 0]
            if len(lab) == 0:
                out.append(-1)
                continue
            counts = np.bincount(lab)
            best = int(np.argmax(counts))
            share = counts[best] / len(mine)
            out.append(best - 1 if share >= self.config.min_match else -1)
        return out

    def execute(self, plan: Any, k: int, snapshots: tuple[float, ...] = ()) -> tuple[dict, Any]:
        """``ExecuteGrasp``: replays ``plan`` on the true objects with object ``k`` the target.

        The world moves on: the objects take the poses they rest in after the replay, an object
        at the drop-off (or off the table) leaves it, and the head camera takes a new frame.

        Returns:
            ``(result, report)``: ``{"delivered", "lifted", "collisions", "slip_mm",
            "tcp_error_mm", "seconds", "knocked_off"}`` and the
            :class:`symjax.motion.ReplayReport`; the true planning scene it ran in is
            :attr:`last_truth` (for pictures).
        """
        from symjax import motion
        from symjax.datasets.scan_scenes import rearranged

        cfg = self.config
        names = [f"obj{i}" for i in range(len(self.alive))]
        truth = motion.PlanningScene(self.robot, {n: self.true_hulls(i).hulls
                                                  for i, n in enumerate(names)})  # fmt: skip
        self.last_truth = truth
        rep = motion.replay(dataclasses.replace(plan, target=names[k]), truth,
                            lift_height=cfg.motion.lift_height, snapshots=snapshots)  # fmt: skip
        drop = np.asarray(self.robot.dropoff[:2])
        h = self.scene.table_height
        keep, poses, knocked = [], [], []
        delivered = False
        # The drop-off is a bin beside the table: the pick succeeds when the object leaves the
        # hand above it and falls off the table (where it lands in the bin is not simulated).
        released = np.asarray(rep.target_released, float)
        for i, n in enumerate(names):
            T = rep.object_motion[n] @ self.scene.poses[i]
            centre = rep.object_motion[n][:3, :3] @ self.scene.meshes[i].centroid \
                + rep.object_motion[n][:3, 3]  # fmt: skip
            if centre[2] < h - 0.02:  # off the table: over the bin, or dropped, or knocked off
                if i == k:
                    delivered = bool(np.hypot(*(released[:2] - drop)) < cfg.dropoff_radius)
                else:
                    knocked.append(self.names[self.alive[i]])
                continue
            keep.append(i)
            poses.append(T)
        result = {
            "delivered": delivered,
            "lifted": bool(rep.lifted),
            "collisions": [list(c) for c in rep.collisions],
            "slip_mm": round(1e3 * float(rep.slip), 1),
            "tcp_error_mm": round(1e3 * float(rep.tcp_error), 2),
            "knocked_off": knocked,
            "seconds": round(rep.seconds, 3),
        }
        self._frame += 1
        self.scene = rearranged(
            self.scene,
            keep,
            np.asarray(poses).reshape(-1, 4, 4),
            seed=cfg.seed * 1000 + self.scene.seed * 17 + self._frame,
        )
        self.alive = [self.alive[i] for i in keep]
        return result, rep
