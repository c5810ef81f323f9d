"""Which robot, hand and grasp generator a job plans for (paper Section III)."""

from __future__ import annotations

import dataclasses
from typing import Literal

from symjax.errors import ConfigError
from symjax.validation import check_fields

__all__ = ["PlatformConfig"]


@dataclasses.dataclass(frozen=True)
class PlatformConfig:
    """One of the paper's two platforms, or a hand alone.

    Attributes:
        robot: ``"kth"`` (Kuka KR 6 arm + Schunk SDH) or ``"uji"`` (Mitsubishi PA10-7C +
            Barrett BH8).
        hand: The hand on the flange: the robot's own (``"sdh"`` on ``"kth"``, ``"barrett"`` on
            ``"uji"``).
        generator: Grasp candidate generator (paper Section IV-A): ``"kth"`` (approach circle
            about the two grasp points), ``"uji"`` (circles about the centroid), ``"openrave"``
            (bounding-box rays).
    """

    robot: Literal["kth", "uji"] = "kth"
    hand: Literal["sdh", "barrett", "parallel_jaw"] = "sdh"
    generator: Literal["kth", "uji", "openrave"] = "kth"

    def __post_init__(self) -> None:
        check_fields(self)
        from symjax.robots.robot import ROBOT_NAMES, robot_hand

        if self.robot not in ROBOT_NAMES:
            raise ConfigError(f"robot = {self.robot!r}; expected one of {', '.join(ROBOT_NAMES)}")
        if self.generator not in ("kth", "uji", "openrave"):
            raise ConfigError(f"generator = {self.generator!r}; expected one of kth, uji, openrave")
        if self.hand != robot_hand(self.robot):
            raise ConfigError(
                f"hand = {self.hand!r} is not on robot {self.robot!r}; expected"
                f" {robot_hand(self.robot)!r}"
            )
