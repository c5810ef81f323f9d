"""Interchangeable rollout backends with one signature, picked from a table.

Each module has ``run(scene, params, execution) -> GraspOutcomes``: ``scene`` a
:class:`~symjax.grasp.scene.GraspScene`, ``params`` the per-candidate arrays of
:func:`~symjax.grasp.schedule.candidate_params`. ``"mjx"`` is MuJoCo XLA (``impl="jax"``),
``"mjx_warp"`` MuJoCo Warp through MJX (NVIDIA GPUs), ``"mujoco"`` C MuJoCo's multi-threaded
rollout.
"""

from __future__ import annotations

import jax

from symjax.grasp.backends import mjx_backend, mujoco_backend, warp_backend

__all__ = ["BACKENDS", "default_backend"]

#: Backend name -> its ``run`` function.
BACKENDS = {"mjx": mjx_backend.run, "mjx_warp": warp_backend.run, "mujoco": mujoco_backend.run}


def default_backend() -> str:
    """On a GPU ``"mjx_warp"`` where MuJoCo Warp is installed, else ``"mjx"``; on a CPU
    ``"mujoco"``."""
    if jax.default_backend() != "gpu":
        return "mujoco"
    return "mjx_warp" if warp_backend.available() else "mjx"
