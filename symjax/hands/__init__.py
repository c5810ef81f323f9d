"""Robot hands (Schunk SDH, Barrett BH8-282, parallel-jaw gripper) as MJCF models."""

from symjax.hands.hand import HAND_NAMES, PRESHAPES, Hand, as_hand, load, probe_points

__all__ = ["as_hand", "HAND_NAMES", "PRESHAPES", "Hand", "load", "probe_points"]
