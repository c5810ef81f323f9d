"""The two robots of the paper (KTH: Kuka + SDH, UJI: PA10-7C + Barrett) as MJCF scenes."""

from symjax.robots.platform import PlatformConfig
from symjax.robots.robot import DH, ROBOT_NAMES, Robot, flange_pose, load, robot_hand

__all__ = ["DH", "ROBOT_NAMES", "PlatformConfig", "Robot", "flange_pose", "load", "robot_hand"]
