"""Hands: loading (C MuJoCo and MJX), pre-shapes, couplings and closing on a cylinder."""

from __future__ import annotations

import jax
import mujoco
import numpy as np
import pytest
from mujoco import mjx
from scipy.spatial.transform import Rotation

from symjax import hands
from symjax.errors import SymjaxError, UnknownNameError

EXPECTED = {"sdh": (8, 7), "barrett": (8, 4), "parallel_jaw": (2, 1)}


@pytest.mark.parametrize("name", hands.HAND_NAMES)
def test_load_counts_and_conventions(name):
    h = hands.load(name)
    nq, nu = EXPECTED[name]
    assert (h.nq, h.nu) == (nq, nu)
    assert h.preshape_qpos.shape == (3, nq) and h.preshape_ctrl.shape == (3, nu)
    assert h.preshape_names == ("home", "open", "pinch")
    m = h.model()
    assert m.nq == nq and m.nu == nu
    # Force-limited actuators and damped joints (an undamped hand diverged in MJX).
    assert np.all(m.actuator_forcelimited) and np.all(m.actuator_forcerange[:, 1] > 0)
    assert np.all(m.dof_damping > 0)
    assert np.all(np.isin(m.geom_condim, (3, 4)))
    # Pre-shapes respect joint ranges and control ranges.
    lo, hi = m.jnt_range.T
    assert np.all(h.preshape_qpos >= lo - 1e-9) and np.all(h.preshape_qpos <= hi + 1e-9)
    assert np.all(h.preshape_ctrl >= h.ctrl_range[:, 0] - 1e-9)
    assert np.all(h.preshape_ctrl <= h.ctrl_range[:, 1] + 1e-9)
    # TCP: unit quaternion, in front of the palm (+z).
    assert abs(np.linalg.norm(h.tcp_quat) - 1) < 1e-9 and h.tcp_pos[2] > 0.05
    # The Barrett SDH-like joint counts: 4 actuated DoF, 8 joints; SDH 7 DoF with 8 joints.
    assert m.neq == len(h.couplings)


def test_unknown_hand_lists_names():
    with pytest.raises(UnknownNameError, match="barrett.*parallel_jaw.*sdh"):
        hands.load("shadow")
    with pytest.raises(SymjaxError):
        hands.load("sdh").preshape_index("fist")


def test_sdh_knuckle_turns_fingers_opposite():
    h = hands.load("sdh")
    m = h.model()
    d = mujoco.MjData(m)
    d.qpos[:] = h.preshape_qpos[h.preshape_index("home")]
    d.ctrl[:] = h.preshape_ctrl[0]
    d.ctrl[h.actuator_names.index("knuckle")] = np.pi / 2
    for _ in range(600):
        mujoco.mj_step(m, d)
    q = dict(zip(h.joint_names, d.qpos, strict=True))
    assert q["f1_base"] == pytest.approx(np.pi / 2, abs=0.05)
    assert q["f2_base"] == pytest.approx(q["f1_base"], abs=0.01)
    # At 90 deg fingers 1 and 2 face each other: their closing directions are opposite.
    mujoco.mj_kinematics(m, d)
    x1 = d.xmat[m.body("f1_proximal").id].reshape(3, 3) @ np.array([0, -1, 0.0])
    x2 = d.xmat[m.body("f2_proximal").id].reshape(3, 3) @ np.array([0, -1, 0.0])
    assert np.dot(x1, x2) == pytest.approx(-1, abs=0.01)


def test_probe_points_in_tcp_frame():
    h = hands.load("sdh")
    p = hands.probe_points(h, "pinch")
    assert p.ndim == 2 and p.shape[1] == 3 and len(p) > 20
    # The palm lies behind the TCP (negative z in the TCP frame).
    assert p[:, 2].min() < -0.15 and p[:, 2].max() > 0.0


def test_closed_ctrl_keeps_preshape_of_unmasked():
    h = hands.load("barrett")
    c = np.asarray(h.closed_ctrl(1))
    assert c[h.actuator_names.index("spread")] == h.preshape_ctrl[1, 0]
    assert c[h.actuator_names.index("f1")] == pytest.approx(2.4435)
    # Works under jit with a traced pre-shape index.
    cj = jax.jit(lambda hh, i: hh.closed_ctrl(i))(h, 1)
    np.testing.assert_allclose(np.asarray(cj), c, atol=1e-6)


def _close_on_cylinder(name: str, steps: int = 1000):
    """Closes the hand from its pinch pre-shape on a 6 cm cylinder held at the TCP."""
    h = hands.load(name)
    spec = h.spec()
    R = Rotation.from_quat(h.tcp_quat, scalar_first=True).as_matrix()
    # Cylinder axis across the closing axis: along the TCP's y axis.
    quat = Rotation.align_vectors([R[:, 1]], [[0, 0, 1.0]])[0].as_quat(scalar_first=True)
    body = spec.worldbody.add_body(name="cylinder", pos=h.tcp_pos, quat=quat)
    body.add_geom(name="cylinder", type=mujoco.mjtGeom.mjGEOM_CYLINDER, size=[0.03, 0.1, 0])
    m = spec.compile()
    d = mujoco.MjData(m)
    p = h.preshape_index("pinch")
    d.qpos[:] = h.preshape_qpos[p]
    d.ctrl[:] = h.preshape_ctrl[p]
    mujoco.mj_forward(m, d)
    assert d.ncon == 0, "the pinch pre-shape must not touch the cylinder"
    d.ctrl[:] = np.asarray(h.closed_ctrl(p))
    for _ in range(steps):
        mujoco.mj_step(m, d)
    cyl = m.geom("cylinder").id
    touching = set()
    for c in d.contact[: d.ncon]:
        if cyl in (c.geom1, c.geom2) and c.dist < 0.002:
            other = c.geom2 if c.geom1 == cyl else c.geom1
            touching.add(m.geom(other).name)
    return h, m, d, touching


@pytest.mark.parametrize("name", hands.HAND_NAMES)
def test_closing_on_cylinder_touches_every_finger_and_keeps_couplings(name):
    h, m, d, touching = _close_on_cylinder(name)
    for finger, geoms in zip(h.finger_names, h.finger_geoms, strict=True):
        assert touching & set(geoms), f"{name}: finger {finger} does not touch ({touching})"
    assert np.all(np.isfinite(d.qpos))
    q = dict(zip(h.joint_names, d.qpos, strict=True))
    for joint, driver, ratio in h.couplings:
        assert q[joint] == pytest.approx(ratio * q[driver], abs=0.02), (joint, driver)
    # Closing moved the fingers (the drivers) away from the pre-shape.
    p0 = dict(zip(h.joint_names, h.preshape_qpos[h.preshape_index("pinch")], strict=True))
    moved = max(abs(q[j] - p0[j]) for j in h.joint_names)
    assert moved > 0.01


@pytest.mark.parametrize("name", hands.HAND_NAMES)
def test_loads_in_mjx(name):
    mx = mjx.put_model(hands.load(name).model())
    assert mx.nq == EXPECTED[name][0]


def test_mjx_forward_smallest_hand():
    h = hands.load("parallel_jaw")
    mx = mjx.put_model(h.model())
    dx = mjx.make_data(mx).replace(qpos=jax.numpy.asarray(h.preshape_qpos[1], dtype=float))
    dx = jax.jit(mjx.forward)(mx, dx)
    site = np.asarray(dx.site_xpos)[0]
    np.testing.assert_allclose(site, h.tcp_pos, atol=1e-5)
    assert np.all(np.isfinite(np.asarray(dx.qacc)))
