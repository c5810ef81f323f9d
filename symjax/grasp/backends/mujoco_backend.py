"""C MuJoCo rollout backend: :func:`mujoco.rollout.rollout`, multi-threaded; the control schedule
and the labels are the same jitted JAX functions as the MJX backend's.
"""

from __future__ import annotations

import functools
import os

import jax
import jax.numpy as jnp
import mujoco
import numpy as np

from symjax.execution import ExecutionConfig
from symjax.geometry import bucket, pad_rows
from symjax.grasp.labels import labels
from symjax.grasp.outcomes import GraspOutcomes
from symjax.grasp.scene import GraspScene
from symjax.grasp.scene_key import bind, object_arrays, static_key
from symjax.grasp.schedule import control, snap_steps

__all__ = ["host_labels", "run"]

_MAX_C_CONTACTS = 64


_COMPILED: dict[tuple, tuple] = {}


def _compiled(scene: GraspScene):
    """``(schedule, labels)`` jitted once per scene structure (:mod:`symjax.grasp.scene_key`)."""
    key = static_key(scene)
    if key in _COMPILED:
        return _COMPILED[key]
    template = scene
    n = scene.config.n_steps

    def schedule(p, arrays):
        sc = bind(template, arrays)

        def one(p):
            ctrl, qfrc, eq = jax.vmap(lambda k: control(sc, k, p))(jnp.arange(n))
            # mjtState bit order: ctrl, qfrc_applied, ..., eq_active.
            return jnp.concatenate([ctrl, qfrc, eq.astype(ctrl.dtype)], axis=-1)

        return jax.vmap(one)(p)

    def label(p, arrays, *rest):
        sc = bind(template, arrays)
        return jax.vmap(functools.partial(labels, sc))(p, *rest)

    if len(_COMPILED) >= 8:
        _COMPILED.pop(next(iter(_COMPILED)))
    _COMPILED[key] = (jax.jit(schedule), jax.jit(label))
    return _COMPILED[key]


def _c_contacts(m, d, qpos: np.ndarray) -> tuple[np.ndarray, ...]:
    B = len(qpos)
    dist = np.full((B, _MAX_C_CONTACTS), np.inf)
    pos = np.zeros((B, _MAX_C_CONTACTS, 3))
    nrm = np.zeros((B, _MAX_C_CONTACTS, 3))
    nrm[..., 2] = 1.0
    g1 = np.zeros((B, _MAX_C_CONTACTS), np.int32)
    g2 = np.zeros((B, _MAX_C_CONTACTS), np.int32)
    for i in range(B):
        mujoco.mj_resetData(m, d)
        d.qpos[:] = qpos[i] if np.all(np.isfinite(qpos[i])) else m.qpos0
        mujoco.mj_forward(m, d)
        c = d.contact
        k = min(d.ncon, _MAX_C_CONTACTS)
        if k:
            order = np.argsort(c.dist[: d.ncon])[:k]  # the deepest when there are too many
            dist[i, :k] = c.dist[order]
            pos[i, :k] = c.pos[order]
            nrm[i, :k] = c.frame[order, :3]
            g1[i, :k] = c.geom1[order]
            g2[i, :k] = c.geom2[order]
    return dist, pos, nrm, g1, g2


def host_labels(scene: GraspScene, padded: dict, qpos: np.ndarray, states: tuple, d,
                arrays: dict) -> dict[str, np.ndarray]:  # fmt: skip
    """Labels of one chunk from its kept states, the contacts found by C MuJoCo on the host.

    Args:
        scene: The grasp scene.
        padded: The chunk's candidate parameters, padded to its size bucket ``P``.
        qpos: (B, nq) the chunk's start states (B <= P).
        states: ``(q_app, q_grasp, q_end, bad)``, the first B rows are the chunk's.
        d: A scratch :class:`mujoco.MjData` of the scene's model.
        arrays: The scene's object arrays as JAX arrays
            (:func:`~symjax.grasp.scene_key.object_arrays`).

    Returns:
        The label arrays of the B candidates.
    """
    _, label = _compiled(scene)
    B, P = len(qpos), len(padded["travel"])
    q_app, q_grasp, q_end, bad = (np.asarray(x)[:B] for x in states)
    gc = _c_contacts(scene.model, d, q_grasp)
    sc = _c_contacts(scene.model, d, qpos)

    def pad(x):
        return jnp.asarray(pad_rows(np.asarray(x), P))

    out = label(
        padded, arrays, pad(q_app), pad(q_grasp), pad(q_end), pad(bad),
        tuple(pad(x) for x in gc), tuple(pad(x) for x in sc),
    )  # fmt: skip
    return {k: np.asarray(v)[:B] for k, v in out.items()}


def run(
    scene: GraspScene, params: dict[str, np.ndarray], execution: ExecutionConfig
) -> GraspOutcomes:
    """Rolls out and labels every candidate of ``params`` (see :mod:`symjax.grasp.backends`)."""
    from mujoco import rollout

    cfg, m = scene.config, scene.model
    nthread = execution.simulation_threads or os.cpu_count() or 1
    datas = [mujoco.MjData(m) for _ in range(nthread)]
    d = datas[0]
    full = mujoco.mjtState.mjSTATE_FULLPHYSICS
    spec = (
        mujoco.mjtState.mjSTATE_CTRL
        | mujoco.mjtState.mjSTATE_QFRC_APPLIED
        | mujoco.mjtState.mjSTATE_EQ_ACTIVE
    )
    nstate = mujoco.mj_stateSize(m, full)
    mujoco.mj_resetData(m, d)
    template = np.empty(nstate)
    mujoco.mj_getState(m, d, template, full)
    q0 = 1  # the state starts with time, then qpos (mjtState bit order)
    i_app, i_grasp, i_end = snap_steps(cfg)
    n = len(params["travel"])
    size = 128  # keeps the (batch, steps, state) trajectory buffer near 50 MB
    sched, _ = _compiled(scene)
    arrays = {k: jnp.asarray(v) for k, v in object_arrays(scene).items()}
    # Zero warm start for every rollout: the solver otherwise starts from whatever the thread's
    # MjData held from its previous rollout, and reruns differ with the thread schedule.
    warm = np.zeros((1, m.nv))
    parts = []
    for s in range(0, n, size):
        chunk = {k: v[s : s + size] for k, v in params.items()}
        B = len(chunk["travel"])
        # Jitted inputs padded to a size bucket: a last chunk of any length reuses a compile.
        P = bucket(B, minimum=16)
        padded = {k: jnp.asarray(pad_rows(v, P)) for k, v in chunk.items()}
        ctrl = np.asarray(sched(padded, arrays), np.float64)[:B]
        init = np.repeat(template[None], B, axis=0)
        init[:, q0 : q0 + m.nq] = chunk["qpos"]
        state, _ = rollout.rollout(m, datas, init, ctrl, control_spec=spec,
                                   initial_warmstart=warm)  # fmt: skip
        qs = state[:, :, q0 : q0 + m.nq]
        # C MuJoCo resets a diverging simulation (and its clock) instead of returning NaN.
        t_end = state[:, -1, 0]
        bad = ~np.all(np.isfinite(state), axis=(1, 2)) | (
            np.abs(t_end - cfg.n_steps * cfg.timestep) > 0.5 * cfg.timestep
        )
        states = (qs[:, i_app], qs[:, i_grasp], qs[:, i_end], bad)
        parts.append(host_labels(scene, padded, chunk["qpos"], states, d, arrays))
    merged = {k: np.concatenate([p[k] for p in parts]) for k in parts[0]}
    return GraspOutcomes(**merged, backend="mujoco")
