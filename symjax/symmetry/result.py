"""The outcome of the symmetry search for one view or a batch of views."""

from __future__ import annotations

import dataclasses
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

from symjax._pytree import pytree_dataclass, static_field
from symjax.errors import ShapeError

__all__ = ["SymmetryResult"]


def _xp(x):
    """numpy for host arrays (a batch's results are kept there), jax.numpy for device arrays
    and tracers: an eager jnp call on host data compiles a small program for every shape."""
    return jnp if isinstance(x, jax.Array) else np


@pytree_dataclass
class SymmetryResult:
    """Outcome of the search for one view (or a batch, with a leading view axis).

    The plane is ``{x : normal . x = offset}``, perpendicular to the table, its normal pointing
    away from the camera. Orientations are angles about the table normal relative to the
    normal of the paper's initial plane (Eq. 1); shifts are metres along the rotated normal from
    the centroid. ``angles``/``shifts``/``votes`` hold the level-0 grid (one n x m fan per initial
    axis; start 0 is the paper's grid), ``refine_*`` the coarse-to-fine levels.

    Attributes:
        normal: (3,) unit plane normal.
        offset: () plane offset, metres.
        angle: () orientation of the best plane, radians.
        shift: () shift of the best plane from the centroid along its normal, metres.
        vote: () vote of the best plane (Eq. 3).
        centroid: (3,) centroid ``c`` of the visible points.
        initial_axis: (3,) initial symmetry axis ``s`` in the table plane (Eq. 1).
        extent: () object extent ``L`` used to scale the shifts, metres.
        angles: (n_starts, n_angles) level-0 orientations, radians.
        shifts: (n_shifts,) level-0 shifts, metres.
        votes: (n_starts, n_angles, n_shifts) level-0 votes ``w_out E[d1] + w_in E[d2]``.
        vote_outside: (n_starts, n_angles, n_shifts) ``E[delta_1]``, pixels^2.
        vote_inside: (n_starts, n_angles, n_shifts) ``E[delta_2]``, metres.
        best_index: (3,) int (start, angle, shift) of the best level-0 hypothesis.
        best_start: () int, the initial axis whose refined chain won (refinement runs per start).
        refine_angles: (n_refine, n_angles) radians, of the winning chain. With ``n_refine=0``
            the ``refine_*`` arrays hold one row of NaN (zero-size leaves do not batch).
        refine_shifts: (n_refine, n_shifts) metres.
        refine_votes: (n_refine, n_angles, n_shifts).
        points: (N, 3) observed points; valid: (N,) their validity.
        mirrored: (N, 3) points mirrored across the best plane.
        mirrored_keep: (N,) mirrored points kept in the completion (valid and not in front of an
            observed surface).
        errors: Batched results only: per view None, or the :class:`~symjax.errors.SymjaxError`
            that kept it from being searched (its float fields are NaN; indexing it raises).
        plausibility: (N,) plausibility in [0, 1] of each mirrored point under the best plane.
    """

    normal: Any
    offset: Any
    angle: Any
    shift: Any
    vote: Any
    centroid: Any
    initial_axis: Any
    extent: Any
    angles: Any
    shifts: Any
    votes: Any
    vote_outside: Any
    vote_inside: Any
    best_index: Any
    best_start: Any
    refine_angles: Any
    refine_shifts: Any
    refine_votes: Any
    points: Any
    valid: Any
    mirrored: Any
    mirrored_keep: Any
    plausibility: Any
    errors: Any = static_field(default=None)

    @property
    def completed_points(self):
        """(2N, 3) observed then mirrored points (use :attr:`completed_valid`)."""
        return _xp(self.points).concatenate([self.points, self.mirrored], axis=-2)

    @property
    def completed_valid(self):
        """(2N,) validity of :attr:`completed_points`."""
        return _xp(self.valid).concatenate([self.valid, self.mirrored_keep], axis=-1)

    @property
    def completed_plausibility(self):
        """(2N,) plausibility of :attr:`completed_points` (1 for observed points)."""
        xp = _xp(self.plausibility)
        return xp.concatenate([xp.ones_like(self.plausibility), self.plausibility], axis=-1)

    def completed_cloud(self) -> np.ndarray:
        """The completed cloud of one view as numpy (M, 3): observed plus kept mirrored points."""
        if np.ndim(self.points) != 2:
            raise ShapeError("completed_cloud() needs one view; index the batch first: result[i]")
        return np.asarray(self.completed_points)[np.asarray(self.completed_valid)]

    def mirrored_cloud(self) -> np.ndarray:
        """Kept mirrored points of one view as numpy (M, 3)."""
        return np.asarray(self.mirrored)[np.asarray(self.mirrored_keep)]

    def __len__(self) -> int:
        if np.ndim(self.points) != 3:
            raise TypeError("a single-view SymmetryResult has no len()")
        return int(np.shape(self.points)[0])

    @property
    def ok(self) -> np.ndarray:
        """(B,) bool of a batched result: which views were searched (see :attr:`errors`)."""
        if self.errors is None:
            return np.ones(len(self), bool)
        return np.array([e is None for e in self.errors])

    def __getitem__(self, i) -> SymmetryResult:
        """The result of view ``i`` of a batched result.

        Raises:
            SymjaxError: View ``i`` could not be searched; the error says why.
        """
        if self.errors is not None and self.errors[i] is not None:
            e = self.errors[i]
            raise type(e)(f"view {i} of the batch was not searched: {e}")
        return dataclasses.replace(jax.tree_util.tree_map(lambda x: x[i], self), errors=None)
