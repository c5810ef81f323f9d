"""A batch of grasp candidates and the generator's output record."""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np

from symjax._pytree import pytree_dataclass
from symjax.grasp.approach import approach_frames

__all__ = ["CandidateSet", "Candidates"]


@pytree_dataclass
class Candidates:
    """A batch of N grasp candidates (every field's leading axis is N).

    Attributes:
        approach: Unit approach vectors, shape (N, 3); the hand moves along them.
        point: Grasp points, shape (N, 3), metres, world frame.
        roll: Roll about the approach, shape (N,), radians (see :func:`approach_frame`).
        preshape: Pre-shape indices into ``symjax.hands.PRESHAPES``, shape (N,), int32.
        distance: Approach distance, shape (N,), metres: the TCP starts at
            ``point - distance * approach``.
    """

    approach: Any
    point: Any
    roll: Any
    preshape: Any
    distance: Any

    def __len__(self) -> int:
        return int(np.shape(self.roll)[0])

    def frames(self):
        """TCP orientations, shape (N, 3, 3): columns are closing axis, y, approach."""
        return approach_frames(self.approach, self.roll)

    def start_positions(self):
        """TCP start positions ``point - distance * approach``, shape (N, 3), metres."""
        return self.point - self.distance[:, None] * self.approach


@dataclasses.dataclass(frozen=True)
class CandidateSet:
    """Output of :func:`generate`.

    Attributes:
        candidates: The kept candidates.
        method: The generator used.
        n_generated: Candidates before the start-pose check.
        n_dropped_table: Dropped because the hand started in (or under) the table.
        n_dropped_object: Dropped because the hand started inside the object.
        n_missed: ``"openrave"`` rays that missed the object (no candidate made).
        seconds: Wall time of the call.
    """

    candidates: Candidates
    method: str
    n_generated: int
    n_dropped_table: int
    n_dropped_object: int
    n_missed: int
    seconds: float

    def __len__(self) -> int:
        return len(self.candidates)
