"""Outcome labels of one rollout from its kept states and contacts (shared by both backends).

The contacts at the end of the settle phase give the force-closure and epsilon labels
(:mod:`symjax.grasp.quality`); the grasp succeeds when the object stayed put relative to the
palm through the lift and shake.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp

from symjax.geometry import quat_to_matrix, rot_zyx, rotation_angle
from symjax.grasp.quality import contact_quality
from symjax.grasp.scene import GraspScene

__all__ = ["START_TOLERANCE", "labels"]

START_TOLERANCE = 0.005  # metres of start-pose penetration still counted as touching


def labels(scene: GraspScene, p, q_app, q_grasp, q_end, diverged, grasp_con, start_con):
    """Outcome fields of one candidate from its kept states and contact arrays (pure JAX)."""
    cfg = scene.config
    gf = jnp.asarray(scene.geom_finger)
    go = jnp.asarray(scene.geom_object)
    gt = jnp.asarray(scene.geom_table)
    nf = len(scene.hand.finger_names)
    ob, bq = scene.qadr_object, scene.qadr_base

    def pose(q):
        return q[bq[:3]], rot_zyx(q[bq[3:]]), q[ob : ob + 3], quat_to_matrix(q[ob + 3 : ob + 7])

    dist, pos, normal, g1, g2 = grasp_con
    hand1, hand2 = gf[g1] >= 0, gf[g2] >= 0
    pair = (hand1 & go[g2]) | (hand2 & go[g1])
    valid = pair & (dist <= cfg.contact_distance)
    into = jnp.where(go[g2][:, None], normal, -normal)  # frame normal points geom1 -> geom2
    finger = jnp.where(hand1, gf[g1], gf[g2])
    # Invalid rows land in the palm slot (index nf), which is not counted.
    touched = jnp.zeros(nf + 1, bool).at[jnp.where(valid, finger, nf)].set(True)
    n_fingers = jnp.sum(touched[:nf].astype(jnp.int32))
    penetration = jnp.maximum(jnp.max(jnp.where(valid, -dist, 0.0)), 0.0)
    table_pair = (hand1 & gt[g2]) | (hand2 & gt[g1])
    table_contact = jnp.any(table_pair & (dist <= cfg.contact_distance))
    K = min(cfg.max_contacts, dist.shape[0])
    _, top = jax.lax.top_k(jnp.where(valid, -dist, -jnp.inf), K)
    b_pos, b_rot, o_pos, o_rot = pose(q_grasp)
    closed, eps = contact_quality(
        pos[top], into[top], valid[top], o_pos,
        friction=cfg.friction, n_edges=cfg.n_edges, rho=scene.radius, torsion=cfg.torsion,
    )  # fmt: skip

    sd, _, _, sg1, sg2 = start_con
    s_hand = (gf[sg1] >= 0) ^ (gf[sg2] >= 0)  # the hand against anything else
    start_pen = jnp.maximum(jnp.max(jnp.where(s_hand, -sd, 0.0)), 0.0)

    q0 = p["qpos"]
    b0, _, o0, r0 = pose(q0)
    ba, _, _, _ = pose(q_app)
    be, Rbe, oe, Roe = pose(q_end)
    travel = jnp.dot(ba - b0, p["approach"])
    close_motion = jnp.linalg.norm(o_pos - o0)
    close_rot = rotation_angle(r0, o_rot)
    rel_g = b_rot.T @ (o_pos - b_pos)
    rel_e = Rbe.T @ (oe - be)
    shake_motion = jnp.linalg.norm(rel_e - rel_g)
    shake_rot = rotation_angle(b_rot.T @ o_rot, Rbe.T @ Roe)
    lift = oe[2] - o_pos[2]
    finite = jnp.all(jnp.isfinite(jnp.stack([
        travel, close_motion, close_rot, shake_motion, shake_rot, lift, eps, penetration,
    ])))  # fmt: skip
    bad = diverged | ~finite
    success = (
        ~bad
        & (shake_motion < cfg.success_distance)
        & (shake_rot < cfg.success_rotation)
        & (lift >= cfg.min_lift)
        & (start_pen <= START_TOLERANCE)
    )

    def clean(x, fill=0.0):
        return jnp.where(bad | ~jnp.isfinite(x), fill, x)

    return {
        "success": success,
        "force_closure": closed & ~bad,
        "epsilon": clean(eps),
        "n_fingers": jnp.where(bad, 0, n_fingers).astype(jnp.int32),
        "n_contacts": jnp.where(bad, 0, jnp.sum(valid)).astype(jnp.int32),
        "penetration": clean(penetration),
        "start_penetration": jnp.where(jnp.isfinite(start_pen), start_pen, 0.0),
        "table_contact": table_contact & ~bad,
        "travel": clean(travel),
        "close_motion": clean(close_motion, jnp.inf),
        "close_rotation": clean(close_rot, jnp.inf),
        "shake_motion": clean(shake_motion, jnp.inf),
        "shake_rotation": clean(shake_rot, jnp.inf),
        "lift": clean(lift),
        "diverged": bad,
        "hand_q": jnp.where(bad, 0.0, jnp.nan_to_num(q_grasp[jnp.asarray(scene.qadr_hand)])),
    }
