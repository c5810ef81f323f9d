"""Settings of the grasp candidate generators (paper Section IV-A)."""

from __future__ import annotations

import dataclasses

from symjax.errors import ConfigError
from symjax.validation import check_fields

__all__ = ["CandidateConfig", "PINCH"]

PINCH = 2
"""Index of the ``pinch`` pre-shape in :data:`symjax.hands.PRESHAPES`."""


@dataclasses.dataclass(frozen=True)
class CandidateConfig:
    """Parameters of :func:`symjax.grasp.candidates.generate`.

    Attributes:
        n_approach: Approach vectors per circle for ``"kth"`` and ``"uji"`` (paper: 5 to 10),
            spread evenly over 0 to 180 deg, both ends included.
        distances: Approach distances, metres (paper: 0 to 0.2 m). The hand starts with its TCP
            ``distance`` before the grasp point along the approach vector.
        preshapes: Pre-shape indices (into ``symjax.hands.PRESHAPES``); the paper uses one pinch.
        n_rays: ``"openrave"``: number of bounding-box surface samples (one ray each).
        n_rolls: ``"openrave"``: rolls per approach, evenly spaced over a full turn.
        box_padding: ``"openrave"``: margin added around the object's bounding box, metres.
        palm_offset: Without a hand, the start pose is checked at a stand-in palm: five points
            ``palm_offset`` behind the TCP (metres), 5 cm apart.
        table_clearance: A start pose with any probe point lower than this above the table
            is dropped, metres.
    """

    n_approach: int = 8
    distances: tuple[float, ...] = (0.0, 0.05, 0.10, 0.15, 0.20)
    preshapes: tuple[int, ...] = (PINCH,)
    n_rays: int = 256
    n_rolls: int = 4
    box_padding: float = 0.01
    palm_offset: float = 0.1
    table_clearance: float = 0.0

    def __post_init__(self):
        check_fields(self)
        if self.n_approach < 1 or self.n_rays < 1 or self.n_rolls < 1:
            raise ConfigError("n_approach, n_rays and n_rolls must be >= 1")
        if not self.distances or any(not 0.0 <= d <= 1.0 for d in self.distances):
            raise ConfigError(f"distances must be non-empty, in [0, 1] m, got {self.distances}")
        if not self.preshapes or any(p < 0 for p in self.preshapes):
            raise ConfigError(f"preshapes must be non-empty indices, got {self.preshapes}")
        if self.box_padding < 0 or self.palm_offset < 0:
            raise ConfigError("box_padding and palm_offset must be >= 0")
