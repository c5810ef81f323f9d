"""Robots: scenes load (C MuJoCo and MJX); flange kinematics match the published DH tables."""

from __future__ import annotations

import itertools

import mujoco
import numpy as np
import pytest
from mujoco import mjx

from symjax import hands, robots
from symjax.errors import ShapeError, UnknownNameError

# Published tables, written out again here (not read from symjax) so that a transcription error
# in either place shows up. Standard DH: T_i = Rz(q_i + offset_i) Tz(d_i) Tx(a_i) Rx(alpha_i).
H = np.pi / 2
PUBLISHED = {
    "kth": dict(  # KR 6 R900 sixx: a = 25, 455, 35; d = 400, 0, 0, 420, 0, 80 mm
        a=[0.025, 0.455, 0.035, 0, 0, 0],
        d=[0.4, 0, 0, 0.42, 0, 0.08],
        alpha=[-H, 0, -H, H, -H, 0],
        offset=[0, -H, 0, 0, 0, 0],
    ),
    "uji": dict(  # PA10-7C: shoulder 315, upper arm 450, forearm 500, flange 80 mm
        a=[0] * 7,
        d=[0.315, 0, 0.45, 0, 0.5, 0, 0.08],
        alpha=[-H, H, -H, H, -H, H, 0],
        offset=[0] * 7,
    ),
}
LIMITS_DEG = {  # published joint limits (Kuka A2/A3 shifted by the DH zero, see README)
    "kth": [(-170, 170), (-100, 135), (-210, 66), (-185, 185), (-120, 120), (-350, 350)],
    "uji": [
        (-177, 177),
        (-94, 94),
        (-174, 174),
        (-137, 137),
        (-255, 255),
        (-165, 165),
        (-255, 255),
    ],
}


def dh_fk(table, q):
    T = np.eye(4)
    for a, d, al, off, qi in zip(
        table["a"], table["d"], table["alpha"], table["offset"], q, strict=True
    ):
        th = qi + off
        ct, st, ca, sa = np.cos(th), np.sin(th), np.cos(al), np.sin(al)
        T = T @ np.array(
            [
                [ct, -st * ca, st * sa, a * ct],
                [st, ct * ca, -ct * sa, a * st],
                [0, sa, ca, d],
                [0, 0, 0, 1],
            ]
        )
    return T


@pytest.mark.parametrize("name", robots.ROBOT_NAMES)
def test_forward_kinematics_matches_published_dh(name):
    r = robots.load(name)
    m = r.model()
    lo, hi = m.jnt_range[: r.n_arm].T
    rng = np.random.default_rng(7)
    qs = [np.zeros(r.n_arm), np.asarray(r.home)]
    qs += [rng.uniform(lo, hi) for _ in range(3)]
    pos, rot = robots.flange_pose(r, np.stack(qs), model=m)
    assert pos.shape == (5, 3) and rot.shape == (5, 3, 3)
    for q, p, R in zip(qs, pos, rot, strict=True):
        T = dh_fk(PUBLISHED[name], q)
        np.testing.assert_allclose(p, T[:3, 3], atol=1e-6)
        np.testing.assert_allclose(R, T[:3, :3], atol=1e-6)
    # Stretched-out reach: Kuka flange 525 mm forward, PA10 flange 1345 mm up at q = 0.
    expected = {"kth": [0.525, 0, 0.89], "uji": [0, 0, 1.345]}[name]
    np.testing.assert_allclose(pos[0], expected, atol=1e-9)


@pytest.mark.parametrize("name", robots.ROBOT_NAMES)
def test_scene_loads_with_hand_table_camera(name):
    r = robots.load(name)
    m = r.model()
    h = hands.load(r.hand)
    assert m.nq == r.n_arm + h.nq and m.nu == r.n_arm + h.nu
    assert m.camera(r.camera).id >= 0 and m.geom(r.table_geom).id >= 0
    np.testing.assert_allclose(np.degrees(m.jnt_range[: r.n_arm]), LIMITS_DEG[name], atol=0.1)
    # Home pose: no contact, hand pointing down above the table.
    d = mujoco.MjData(m)
    mujoco.mj_resetDataKeyframe(m, d, m.key("home").id)
    mujoco.mj_forward(m, d)
    assert d.ncon == 0
    tcp = d.site(r.hand_prefix + "tcp")
    assert tcp.xpos[2] > r.table_height(m) + 0.1
    assert tcp.xmat.reshape(3, 3)[2, 2] < -0.99
    # The hand's couplings survive the attachment.
    assert m.neq == len(h.couplings)
    mx = mjx.put_model(m)
    assert mx.nq == m.nq


def test_unknown_robot_and_bad_q():
    with pytest.raises(UnknownNameError, match="kth.*uji"):
        robots.load("pr2")
    with pytest.raises(ShapeError):
        robots.flange_pose(robots.load("kth"), np.zeros(7))


@pytest.mark.parametrize("name", ["kth", "uji"])
def test_home_clears_the_tallest_scene_object(name):
    # The scene scans stand up to 0.27 m (the spray bottle); on the KTH arm's first, lower
    # pedestal the open hand at home was 0.13 m above the table and 3 of 20 scenes started in
    # collision; the UJI arm's first home held the TCP 0.245 m above the workspace (scene 7).
    import trimesh

    from symjax.motion import PlanningScene

    r = robots.load(name)
    post = trimesh.creation.box((0.08, 0.08, 0.28))
    from symjax.datasets.scan_scenes import _WORKSPACE

    (x0, x1), (y0, y1) = _WORKSPACE
    for x, y in itertools.product(np.linspace(x0, x1, 4), np.linspace(y0, y1, 5)):
        post_w = post.copy()
        post_w.apply_translation((x, y, r.table_height() + 0.14))
        scene = PlanningScene(r, {"post": [(post_w.vertices, post_w.faces)]})
        assert not scene.collisions(scene.full_q(r.home)), (x, y)
