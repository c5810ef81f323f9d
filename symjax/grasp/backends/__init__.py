"""Interchangeable rollout backends with one signature, picked from a table.

Each module has ``run(scene, params, execution) -> GraspOutcomes``: ``scene`` a
:class:`~symjax.grasp.scene.GraspScene`, ``params`` the per-candidate arrays of
:func:`~symjax.grasp.schedule.candidate_params`. ``"mjx"`` is MuJoCo XLA (``impl="jax"``),
``"mujoco"`` C MuJoCo's multi-threaded rollout.
"""

from __future__ import annotations

import jax

from symjax.grasp.backends import mjx_backend, mujoco_backend

__all__ = ["BACKENDS", "default_backend"]

#: Backend name -> its ``run`` function.
BACKENDS = {"mjx": mjx_backend.run, "mujoco": mujoco_backend.run}


def default_backend() -> str:
    """``"mjx"`` when JAX's default device is a GPU, else ``"mujoco"``."""
    return "mjx" if jax.default_backend() == "gpu" else "mujoco"
