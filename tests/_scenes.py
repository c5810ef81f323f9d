"""Test-side names for the synthetic primitive views of :mod:`symjax.datasets.primitives`."""

from __future__ import annotations

import jax.numpy as jnp
import numpy as np

from symjax.datasets.primitives import K_DEFAULT, primitive_shape, primitive_view, symmetry_truth
from symjax.metrics import plane_error as _plane_error
from symjax.symmetry import prepare_view

shape = primitive_shape
view = primitive_view


def plane_error(normal, offset, true_normals) -> tuple[float, float]:
    """Plane error of a found plane against a primitive's true planes (or its axis)."""
    return _plane_error(normal, offset, **symmetry_truth(true_normals))


def float64_view(obs):
    """The kernel's view of ``obs`` in float64, points and camera taken from the float64
    observation (call inside ``jax.enable_x64(True)``): comparisons with the numpy reference
    then check the formula, not float32 rounding of points lying on a pixel edge."""
    import dataclasses

    import jax

    view = jax.tree_util.tree_map(
        lambda x: x.astype(jnp.float64) if jnp.issubdtype(x.dtype, jnp.floating) else x,
        prepare_view(obs),
    )
    T = np.asarray(obs.camera.T_world_cam)
    return dataclasses.replace(
        view,
        points=jnp.asarray(obs.points, jnp.float64),
        R_wc=jnp.asarray(T[:3, :3], jnp.float64),
        t_wc=jnp.asarray(T[:3, 3], jnp.float64),
        K=jnp.asarray(obs.camera.K, jnp.float64),
    )


__all__ = ["K_DEFAULT", "float64_view", "plane_error", "shape", "view"]
