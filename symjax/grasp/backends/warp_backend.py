"""MJX-Warp rollout backend: MuJoCo Warp through MJX (``impl="warp"``, NVIDIA GPUs, the
``mujoco-mjx[warp]`` extra). The dynamics run on the GPU (the same ``vmap`` over candidates and
``lax.scan`` over steps as the MJX-JAX backend); the contacts of the start and grasp states,
which Warp pools across worlds, are recomputed by C MuJoCo from those states on the host, and
the labels are the same jitted function as the C backend's.
"""

from __future__ import annotations

import functools

import jax
import jax.numpy as jnp
import numpy as np

from symjax.errors import SimulationError
from symjax.execution import ExecutionConfig
from symjax.geometry import pad_rows
from symjax.grasp.backends.mjx_backend import chunk_size, rollout_states, shard_batch
from symjax.grasp.outcomes import GraspOutcomes
from symjax.grasp.scene import GraspScene

__all__ = ["available", "run"]


def available() -> bool:
    """Whether MJX's Warp implementation is installed (it also runs on the CPU, slowly)."""
    try:
        import warp  # noqa: F401
        from mujoco import mjx  # noqa: F401
    except ImportError:
        return False
    return True


@functools.lru_cache(maxsize=8)
def _warp_runner(scene: GraspScene, batch: int):
    from mujoco import mjx

    mx = mjx.put_model(scene.model, impl="warp")
    cfg = scene.config
    per_world = int(cfg.mjx_max_contacts or 64)
    # naconmax and njmax count over every batched world.
    d0 = mjx.make_data(scene.model, impl="warp", naconmax=batch * per_world,
                       njmax=per_world * 6)  # fmt: skip

    def one(p):
        d, q_app, q_grasp, bad = rollout_states(scene, mx, d0, p)
        return q_app, q_grasp, d.qpos, bad

    return jax.jit(jax.vmap(one, in_axes=(0,)))


def run(
    scene: GraspScene, params: dict[str, np.ndarray], execution: ExecutionConfig
) -> GraspOutcomes:
    """Rolls out and labels every candidate of ``params`` (see :mod:`symjax.grasp.backends`).

    Raises:
        SimulationError: MJX's Warp implementation is not available here.
    """
    if not available():
        raise SimulationError(
            "backend 'mjx_warp' needs the warp package (pip install 'symjax[warp]', which"
            " installs 'mujoco-mjx[warp]'); use backend 'mjx' or 'mujoco'"
        )
    import mujoco

    from symjax.grasp.backends.mujoco_backend import host_labels
    from symjax.grasp.scene_key import object_arrays

    n = len(params["travel"])
    size = chunk_size(n, execution)
    fn = _warp_runner(scene, size)
    arrays = {k: jnp.asarray(v) for k, v in object_arrays(scene).items()}
    d = mujoco.MjData(scene.model)
    parts = []
    for s in range(0, n, size):
        chunk = {k: v[s : s + size] for k, v in params.items()}
        padded = {k: jnp.asarray(pad_rows(v, size)) for k, v in chunk.items()}
        states = fn(shard_batch(padded, size))  # (q_app, q_grasp, q_end, bad), device arrays
        parts.append(host_labels(scene, padded, chunk["qpos"], states, d, arrays))
    merged = {k: np.concatenate([p[k] for p in parts]) for k in parts[0]}
    return GraspOutcomes(**merged, backend="mjx_warp")
