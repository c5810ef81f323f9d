"""A batch of grasp candidates and the generator's output record."""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np

from symjax._pytree import pytree_dataclass
from symjax.errors import InvalidInputError, ShapeError
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

    def take(self, index: Any) -> Candidates:
        """The candidates at ``index`` (integer array, boolean mask or slice), numpy arrays."""
        if isinstance(index, slice):
            return dataclasses.replace(self, **{k: np.asarray(v)[index] for k, v in self._items()})
        idx = np.asarray(index)
        if idx.dtype == bool:
            if idx.shape != (len(self),):
                raise ShapeError(f"a mask must have shape ({len(self)},), got {idx.shape}")
            idx = np.flatnonzero(idx)
        if idx.dtype.kind not in "iu":
            raise InvalidInputError(f"index must be integers, a mask or a slice, got {idx.dtype}")
        idx = idx.reshape(-1)
        if idx.size and (idx.min() < -len(self) or idx.max() >= len(self)):
            raise InvalidInputError(f"index out of range for {len(self)} candidates")
        return dataclasses.replace(self, **{k: np.asarray(v)[idx] for k, v in self._items()})

    def __getitem__(self, index: Any) -> Candidates:
        if isinstance(index, (int, np.integer)):
            index = [index]
        return self.take(index)

    @staticmethod
    def concatenate(batches: Any) -> Candidates:
        """One batch of the candidates of several, in order."""
        batches = list(batches)
        if not batches or not all(isinstance(b, Candidates) for b in batches):
            raise InvalidInputError("concatenate needs a non-empty list of Candidates")
        names = [f.name for f in dataclasses.fields(Candidates)]
        return Candidates(**{k: np.concatenate([np.asarray(getattr(b, k)) for b in batches])
                             for k in names})  # fmt: skip

    def _items(self):
        return [(f.name, getattr(self, f.name)) for f in dataclasses.fields(self)]

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
