"""Candidate set-up and the open-loop control schedule shared by both rollout backends.

Every candidate runs the same phases (:class:`SimulationConfig`): the hand moves along its
approach vector until the velocity servo stalls against the object or the table (first contact,
no contact logic needed) or its travel ends; the weld releases and the fingers close to the
pre-shape's closing targets under the actuators' force limits; the hand then lifts and shakes.
The object's weight is cancelled by an applied force on its free joint until the closure test
(``SimulationConfig.gravity_after_closure``), so gravity is switched on by the schedule like
every other input. The controls never depend on the state, so both backends run identical
inputs.
"""

from __future__ import annotations

import jax.numpy as jnp
import numpy as np

from symjax.errors import (
    EmptyInputError,
    InvalidInputError,
    ShapeError,
)
from symjax.geometry import euler_zyx, quat_to_matrix
from symjax.grasp.candidates import Candidates
from symjax.grasp.scene import GraspScene
from symjax.grasp.sim_config import SimulationConfig

__all__ = ["candidate_params", "check_candidates", "control", "snap_steps"]


def candidate_params(scene: GraspScene, cands: Candidates) -> dict[str, np.ndarray]:
    """Per-candidate start pose, approach and hand targets (numpy, float64)."""
    hand, cfg = scene.hand, scene.config
    approach = np.asarray(cands.approach, np.float64)
    R_tcp = np.asarray(cands.frames(), np.float64)
    R_t = np.asarray(quat_to_matrix(jnp.asarray(hand.tcp_quat)), np.float64)
    R_base = R_tcp @ R_t.T
    start = np.asarray(cands.start_positions(), np.float64)
    base_pos = start - R_base @ np.asarray(hand.tcp_pos, np.float64)
    euler = np.asarray(euler_zyx(jnp.asarray(R_base)), np.float64)
    pre = np.asarray(cands.preshape, np.int64)
    travel = np.minimum(np.asarray(cands.distance, np.float64) + cfg.overshoot, cfg.max_travel)
    qpos = np.repeat(scene.model.qpos0[None], len(cands), axis=0)
    qpos[:, scene.qadr_base[:3]] = base_pos
    qpos[:, scene.qadr_base[3:]] = euler
    qpos[:, scene.qadr_hand] = np.asarray(hand.preshape_qpos)[pre]
    closed = np.asarray(hand.closed_ctrl(jnp.asarray(pre)))
    return {
        "qpos": qpos,
        "approach": approach,
        "euler": euler,
        "travel": travel,
        "pre_ctrl": np.asarray(hand.preshape_ctrl)[pre],
        "close_ctrl": closed,
    }


def check_candidates(cands: Candidates) -> None:
    if not isinstance(cands, Candidates):
        raise InvalidInputError(f"candidates must be a Candidates batch, got {type(cands)}")
    a = np.asarray(cands.approach)
    n = len(cands)
    if n == 0:
        raise EmptyInputError("no grasp candidates to simulate")
    if a.shape != (n, 3) or np.shape(cands.point) != (n, 3) or np.shape(cands.distance) != (n,):
        raise ShapeError("candidate arrays must be approach/point (N, 3), roll/distance (N,)")
    for x in (a, cands.point, cands.roll, cands.distance):
        if not np.all(np.isfinite(np.asarray(x))):
            raise InvalidInputError("candidates contain NaN or inf")
    length = np.linalg.norm(a.astype(np.float64), axis=1)
    off = np.abs(length - 1.0) > 1e-3
    if off.any():
        raise InvalidInputError(
            f"{int(off.sum())} of {n} approach vectors are not unit length (lengths"
            f" {length[off].min():.4g} to {length[off].max():.4g}); expected unit vectors: the"
            " hand's start, speed and travel are set along them"
        )
    if np.any(np.asarray(cands.distance) < 0):
        raise InvalidInputError("candidate approach distances must be >= 0 metres")


def control(scene: GraspScene, k, p):
    """Controls, applied forces and equality switches at step ``k`` of one candidate (pure JAX).

    Returns:
        ``(ctrl (nu,), qfrc_applied (nv,), eq_active (neq,) bool)``.
    """
    cfg = scene.config
    A, C, S, L, K = cfg.phase_steps
    dt = cfg.timestep
    t = k * dt
    moving = (k < A) & (t < p["travel"] / cfg.approach_speed)
    v = jnp.where(moving, cfg.approach_speed, 0.0) * p["approach"]
    k_lift = k - (A + C + S)
    v = v + jnp.where((k_lift >= 0) & (k_lift < L), cfg.lift_height / cfg.lift_time, 0.0) * (
        jnp.array([0.0, 0.0, 1.0])
    )
    w = 2.0 * jnp.pi * cfg.shake_frequency
    k_shake = k_lift - L
    shake = cfg.shake_amplitude * w * jnp.cos(w * k_shake * dt)
    axis = jnp.array([1.0, 0.0, 1.0]) / jnp.sqrt(2.0)
    v = v + jnp.where(k_shake >= 0, shake, 0.0) * axis
    frac = jnp.clip((k - A + 1) / C, 0.0, 1.0)
    hand_ctrl = p["pre_ctrl"] + frac * (p["close_ctrl"] - p["pre_ctrl"])
    ctrl = jnp.zeros(scene.model.nu, dtype=p["euler"].dtype)
    ctrl = ctrl.at[scene.act_slide].set(v)
    ctrl = ctrl.at[scene.act_hinge].set(p["euler"])
    ctrl = ctrl.at[scene.act_hand].set(hand_ctrl)
    eq = jnp.ones(scene.model.neq, dtype=bool).at[scene.weld].set(k < A)
    weightless = cfg.gravity_after_closure & (k < A + C + S)
    lift_force = jnp.where(weightless, scene.mass * -scene.model.opt.gravity[2], 0.0)
    qfrc = jnp.zeros(scene.model.nv, dtype=ctrl.dtype).at[scene.dadr_object + 2].set(lift_force)
    return ctrl, qfrc, eq


def snap_steps(config: SimulationConfig) -> tuple[int, int, int]:
    """Indices of the steps whose end states are kept: approach, grasp (settle), final."""
    A, C, S, L, K = config.phase_steps
    return A - 1, A + C + S - 1, A + C + S + L + K - 1
