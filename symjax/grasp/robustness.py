"""Robustness of a grasp to the hand's pose: the stable grasps rolled out again at nearby hand
poses, so that the ranking prefers grasps that do not hinge on the exact shape (beyond the paper,
which ranks by one rollout per candidate).

A grasp planned on a completed or partial mesh meets a true surface that lies a few millimetres
elsewhere; to the rollout that is much the same as the hand arriving a little off. Among the
grasps that hold on the planning mesh, those that still hold when the hand is shifted across
and along its closing axis and rolled about its approach are the ones to try first.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable

import numpy as np

from symjax.array_types import ArrayLike
from symjax.errors import ConfigError, ShapeError
from symjax.grasp.candidate_set import Candidates
from symjax.validation import check_fields

__all__ = ["RobustnessConfig", "perturbed_candidates", "pose_robustness"]


@dataclasses.dataclass(frozen=True)
class RobustnessConfig:
    """Hand-pose perturbations of :func:`symjax.grasp.plan`'s ranking.

    Attributes:
        enabled: Roll each stable grasp out again at the perturbed poses and rank the stable
            grasps by the share of poses that hold (the paper ranks by the one rollout: off).
        shift: Shift of the grasp point along the hand's closing axis and along its other
            axis across the approach, both signs (four poses), metres.
        roll_deg: Roll about the approach, both signs (two poses), degrees.
        max_grasps: At most this many stable grasps are rolled out again, the best first by
            the one-rollout ranking; the stable grasps after them keep that order, behind them.
    """

    enabled: bool = False
    shift: float = 0.01
    roll_deg: float = 15.0
    max_grasps: int = 10

    def __post_init__(self) -> None:
        check_fields(self)
        if not 0.0 <= self.shift <= 0.1:
            raise ConfigError(f"RobustnessConfig.shift must be in [0, 0.1] m, got {self.shift}")
        if not 0.0 <= self.roll_deg <= 90.0:
            raise ConfigError(
                f"RobustnessConfig.roll_deg must be in [0, 90] degrees, got {self.roll_deg}"
            )
        if self.max_grasps < 1:
            raise ConfigError(f"RobustnessConfig.max_grasps must be >= 1, got {self.max_grasps}")
        if self.enabled and self.shift == 0.0 and self.roll_deg == 0.0:
            raise ConfigError(
                "RobustnessConfig is enabled with shift 0 and roll_deg 0: no pose to try;"
                " expected shift > 0 or roll_deg > 0"
            )

    @property
    def n_poses(self) -> int:
        """Perturbed poses per grasp."""
        return 4 * (self.shift > 0) + 2 * (self.roll_deg > 0)


def perturbed_candidates(candidates: Candidates, config: RobustnessConfig) -> Candidates:
    """The candidates at every perturbed pose, pose-major: shape (P * N,) for P poses.

    Args:
        candidates: N candidates.
        config: The perturbations (:attr:`RobustnessConfig.n_poses` of them).

    Returns:
        A :class:`Candidates` batch, the N candidates at the first pose, then at the second, ...
    """
    frames = candidates.frames()  # (N, 3, 3): closing axis, y, approach
    point = np.asarray(candidates.point, np.float64)
    roll = np.asarray(candidates.roll, np.float64)
    out = []
    if config.shift > 0:
        for axis in (0, 1):
            for sign in (1.0, -1.0):
                moved = point + sign * config.shift * frames[:, :, axis]
                out.append(dataclasses.replace(candidates, point=moved))
    if config.roll_deg > 0:
        for sign in (1.0, -1.0):
            turned = roll + sign * math.radians(config.roll_deg)
            out.append(dataclasses.replace(candidates, roll=turned))
    return Candidates.concatenate(out)


def pose_robustness(
    candidates: Candidates,
    success: ArrayLike,
    rollout: Callable[[Candidates], ArrayLike],
    config: RobustnessConfig,
    order: ArrayLike | None = None,
) -> np.ndarray:
    """Share of the poses (the planned one and the perturbed ones) at which a grasp holds.

    Only grasps that hold at the planned pose are rolled out again (one batch), at most
    ``config.max_grasps`` of them, the first in ``order``; the others score 0.

    Args:
        candidates: N candidates.
        success: (N,) their success at the planned pose.
        rollout: Rolls a batch of candidates out, returning its (M,) success (the same scene
            the planned poses were rolled out in).
        config: The perturbations.
        order: (N,) indices, the preferred first (the one-rollout ranking); None = as given.

    Returns:
        (N,) float64 in [0, 1].

    Raises:
        ShapeError: ``success`` is not (N,).
    """
    ok = np.asarray(success, bool)
    if ok.shape != (len(candidates),):
        raise ShapeError(f"success must have shape ({len(candidates)},), got {ok.shape}")
    out = np.zeros(len(candidates))
    first = np.arange(len(ok)) if order is None else np.asarray(order, np.int64)
    held = first[ok[first]][: config.max_grasps]
    if len(held) == 0:
        return out
    p = config.n_poses
    moved = np.asarray(rollout(perturbed_candidates(candidates.take(held), config)), float)
    out[held] = (1.0 + moved.reshape(p, len(held)).sum(axis=0)) / (1.0 + p)
    return out
