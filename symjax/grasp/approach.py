"""The TCP frame of a candidate: its z axis the approach, its x axis (the closing axis) set by
the roll about the approach.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np

from symjax.array_types import ArrayLike
from symjax.geometry import bucket, pad_rows

__all__ = ["approach_frame", "approach_frames", "roll_for_axis", "rolls_for_axes"]


def _reference_axes(a):
    """Two unit vectors spanning the plane normal to unit ``a``: world z projected, then a x z."""
    ref = jnp.where(jnp.abs(a[2]) < 0.99, jnp.array([0.0, 0.0, 1.0]), jnp.array([1.0, 0.0, 0.0]))
    e1 = ref - jnp.dot(ref, a) * a
    e1 = e1 / jnp.linalg.norm(e1)
    return e1, jnp.cross(a, e1)


def approach_frame(approach: jax.Array, roll: jax.Array) -> jax.Array:
    """TCP orientation of one candidate, shape (3, 3).

    The z column is ``approach``; the x column (closing axis) is ``cos(roll) e1 + sin(roll) e2``
    with ``e1`` the world z axis (world x if the approach is vertical) projected normal to the
    approach and ``e2 = approach x e1``.

    Args:
        approach: Unit vector, shape (3,).
        roll: Radians, scalar.
    """
    a = approach / jnp.linalg.norm(approach)
    e1, e2 = _reference_axes(a)
    x = jnp.cos(roll) * e1 + jnp.sin(roll) * e2
    return jnp.stack([x, jnp.cross(a, x), a], axis=-1)


def roll_for_axis(approach: jax.Array, axis: jax.Array) -> jax.Array:
    """The roll that points the closing axis along ``axis`` (projected normal to the approach)."""
    a = approach / jnp.linalg.norm(approach)
    e1, e2 = _reference_axes(a)
    return jnp.arctan2(jnp.dot(axis, e2), jnp.dot(axis, e1))


_frames_jit = jax.jit(jax.vmap(approach_frame))
_rolls_jit = jax.jit(jax.vmap(roll_for_axis))


def approach_frames(approach: ArrayLike, roll: ArrayLike) -> np.ndarray:
    """TCP orientations of N candidates, (N, 3, 3) float32 (see :func:`approach_frame`).

    Args:
        approach: (N, 3) approach vectors.
        roll: (N,) rolls, radians.
    """
    a = np.asarray(approach, np.float32).reshape(-1, 3)
    n = bucket(len(a), minimum=64)
    r = pad_rows(np.asarray(roll, np.float32).reshape(-1), n)
    return np.asarray(_frames_jit(pad_rows(a, n), r))[: len(a)]


def rolls_for_axes(approach: ArrayLike, axis: ArrayLike) -> np.ndarray:
    """Rolls (N,) that point the closing axes along ``axis`` (N, 3) or one (3,) for all."""
    a = np.asarray(approach, np.float32).reshape(-1, 3)
    ax = np.broadcast_to(np.asarray(axis, np.float32), a.shape)
    n = bucket(len(a), minimum=64)
    return np.asarray(_rolls_jit(pad_rows(a, n), pad_rows(ax, n)))[: len(a)]
