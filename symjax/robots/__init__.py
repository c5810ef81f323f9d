"""The two robots of the paper (KTH: Kuka + SDH, UJI: PA10-7C + Barrett) as MJCF scenes."""

from symjax.robots.robot import DH, ROBOT_NAMES, Robot, flange_pose, load

__all__ = ["DH", "ROBOT_NAMES", "Robot", "flange_pose", "load"]
