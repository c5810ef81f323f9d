"""Arm motion: mink IK against the DH tables, RRT-Connect around obstacles, the collision limit
near the table, carrying an object, time parameterisation, and replay in C MuJoCo."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest
import trimesh
from test_robots import PUBLISHED, dh_fk

from symjax import motion, robots
from symjax.motion.timing import time_path
from symjax.motion.transit import segment_valid

DOWN = np.diag([1.0, -1.0, -1.0])  # TCP approach (z) pointing down, closing axis along x


def box(size, centre):
    b = trimesh.creation.box(size)
    b.apply_translation(centre)
    return [(np.asarray(b.vertices), np.asarray(b.faces))]


@pytest.fixture(scope="module")
def scenes():
    return {name: motion.PlanningScene(name) for name in robots.ROBOT_NAMES}


def _flange_to_tcp(scene):
    m = scene.scene_model().model
    d = mujoco.MjData(m)
    d.qpos[:] = scene.full_q(scene.robot.home)
    mujoco.mj_kinematics(m, d)
    f, t = m.site(scene.robot.flange_site).id, m.site(scene.robot.tcp_site).id
    Rf = d.site_xmat[f].reshape(3, 3)
    T = np.eye(4)
    T[:3, :3] = Rf.T @ d.site_xmat[t].reshape(3, 3)
    T[:3, 3] = Rf.T @ (d.site_xpos[t] - d.site_xpos[f])
    base = np.eye(4)
    b = m.body(scene.robot.arm_base).id
    base[:3, :3], base[:3, 3] = d.xmat[b].reshape(3, 3), d.xpos[b]
    return base, T


@pytest.mark.parametrize("name", robots.ROBOT_NAMES)
def test_ik_reaches_pose_grid_and_matches_dh(scenes, name):
    scene = scenes[name]
    ik = motion.ArmIK(scene, motion.MotionConfig())
    base, flange_tcp = _flange_to_tcp(scene)
    home = np.asarray(scene.robot.home)
    rng = np.random.default_rng(0)
    q0 = scene.full_q(home)
    reached = 0
    # Targets: TCP poses of configurations around home (reachable by construction).
    offsets = rng.uniform(-0.25, 0.25, size=(12, scene.robot.n_arm))
    for off in offsets:
        q_t = scene.full_q(home + off)
        p, R = scene.tcp_pose(q_t)
        r = ik.solve(p, R, q0)
        if not r.converged:
            assert r.reachable, "a pose of a valid configuration came back unreachable"
            continue  # reachable, but every solution collides: allowed, not counted
        reached += 1
        assert r.position_error < 1e-3 and r.orientation_error < np.radians(1.0)
        # The reached configuration's flange by the published DH table, composed with the
        # flange-to-TCP offset, lands on the target too.
        T = base @ dh_fk(PUBLISHED[name], r.q[: scene.robot.n_arm]) @ flange_tcp
        assert np.linalg.norm(T[:3, 3] - p) < 1.5e-3
        c = (np.trace(T[:3, :3].T @ R) - 1) / 2
        assert np.degrees(np.arccos(np.clip(c, -1, 1))) < 1.5
    assert reached >= 9


@pytest.mark.parametrize("name", robots.ROBOT_NAMES)
def test_outside_workspace_is_unreachable(scenes, name):
    scene = scenes[name]
    far = np.array([2.5, 0.0, 1.0])
    g = motion.GraspPose((far, DOWN), (far - [0, 0, 0.05], DOWN), 1)
    plan = motion.plan_arm(scene, g)
    assert plan.status == "unreachable"
    assert "mm" in plan.reason and len(plan.t) == 0 and not plan.ok


def test_rrt_connect_goes_around_a_box_and_replay_is_clean():
    # Both stand on the table (top at 0.75 m): a wall sunk into it would be thrown out by the
    # replay, whose objects are free bodies.
    target, wall = (0.75, -0.3, 0.81), (0.7, -0.15, 0.951)
    scene = motion.PlanningScene(
        "uji", {"target": box((0.05, 0.05, 0.12), target), "wall": box((0.04, 0.04, 0.4), wall)},
        target="target",
    )  # fmt: skip
    cfg = motion.MotionConfig()
    g = motion.GraspPose(
        (np.array([0.75, -0.3, 0.93]), DOWN), (np.array([0.75, -0.3, 0.85]), DOWN), 1
    )
    plan = motion.plan_arm(scene, g, config=cfg)
    assert plan.ok, plan.reason
    assert plan.planners["transit"] == "rrt_connect"
    # The straight joint-space line from home to the pre-grasp goes through the wall.
    q0 = scene.full_q(scene.robot.home, 1)
    q_pre = scene.full_q(plan.segment("approach")[1][0], 1)
    assert not segment_valid(scene, q0, q_pre, cfg.check_step)
    assert [s for s, _, _ in plan.segments] == list(motion.SEGMENTS)
    rep = motion.replay(plan, scene)
    assert rep.collision_free, rep.collisions
    assert rep.tcp_error < 5e-3
    assert rep.lifted
    # Every OMPL query starts from the same seed: after another query (other RRT samples), the
    # same plan comes out bit for bit, as in a fresh process.
    other = motion.GraspPose(
        (np.array([0.7, -0.3, 0.93]), DOWN), (np.array([0.7, -0.3, 0.88]), DOWN), 1
    )
    motion.plan_arm(scene, other, config=cfg)
    again = motion.plan_arm(scene, g, config=cfg)
    np.testing.assert_array_equal(again.q, plan.q)


def test_approach_near_the_table_keeps_the_hand_off_it():
    # mink's CollisionAvoidanceLimit alone let the Barrett's distal links reach the table box
    # (-0.2 mm instead of its 5 mm): the straight-line motion therefore also checks every
    # waypoint against the scene's margin and stops at the last one that keeps it.
    scene = motion.PlanningScene("uji")
    cfg = motion.MotionConfig()
    scene.margin = cfg.check_margin
    ik = motion.ArmIK(scene, cfg)
    table = scene.robot.table_height()
    q0 = scene.full_q(scene.robot.home)
    pre = ik.solve(np.array([0.7, 0.0, table + 0.25]), DOWN, q0)
    assert pre.converged
    # The TCP 5 mm above the table: the fingertips would be in it.
    path, err, _, col = ik.line(pre.q, np.array([0.7, 0.0, table + 0.005]), DOWN)
    assert path and col and err > 1e-2
    assert all("table" in (a, b) for a, b, _ in col)
    sm = scene.scene_model()
    m, d = sm.model, sm.data

    def table_gaps(path):
        out = []
        for q in path:
            d.qpos[:] = q
            mujoco.mj_kinematics(m, d)
            out.append(min(mujoco.mj_geomDistance(m, d, int(h), int(sm.fixed_geoms[0]), 0.1, None)
                           for h in sm.hand_geoms))  # fmt: skip
        return out

    gaps = table_gaps(path)
    assert min(gaps) >= cfg.check_margin - 1e-4
    assert gaps[-1] < 0.02  # it got close
    # The final approach's own margin (the cycle's 1 mm): closer to the table, never into it.
    scene.table_margin = 0.001
    try:
        path2, _, _, col2 = ik.line(pre.q, np.array([0.7, 0.0, table + 0.005]), DOWN, table=0.001)
    finally:
        scene.table_margin = None
    assert path2 and col2, col2
    near = table_gaps(path2)
    assert 0.001 - 1e-4 <= min(near) < cfg.check_margin, (col2, near[-3:])


def test_attached_object_is_carried_around_an_obstacle():
    # A post between the lift and the drop-off: the transfer must go around it, carrying the
    # box, and neither the arm nor the box may touch it in the replay.
    target = (0.6, 0.25, 0.81)
    scene = motion.PlanningScene(
        "uji",
        {"target": box((0.05, 0.05, 0.12), target),
         "post": box((0.05, 0.05, 0.5), (0.42, 0.42, 1.0))},
        target="target",
    )  # fmt: skip
    g = motion.GraspPose(
        (np.array([0.6, 0.25, 0.93]), DOWN), (np.array([0.6, 0.25, 0.85]), DOWN), 1
    )
    plan = motion.plan_arm(scene, g)
    assert plan.ok, plan.reason
    rep = motion.replay(plan, scene)
    assert rep.collision_free, rep.collisions
    assert not [c for c in rep.object_contacts if "post" in c[1]]
    assert rep.lifted
    # The box leaves the hand over the drop-off and its motion maps where it stood to where it
    # ends (the post, a free body too, stands off the table's edge and falls to the floor).
    assert set(rep.object_motion) == {"target", "post"}
    drop = np.asarray(scene.robot.dropoff)
    assert np.hypot(*(rep.target_released[:2] - drop[:2])) < 0.1
    T = rep.object_motion["target"]
    start = np.concatenate([v for v, _ in box((0.05, 0.05, 0.12), target)]).mean(axis=0)
    assert np.linalg.norm(T[:3, :3] @ start + T[:3, 3] - rep.target_final) < 0.02
    # The scene is left as it was: nothing attached, the box back at its place.
    assert scene.attached is None
    assert np.allclose(scene.object_pose("target")[0], 0)


def test_attach_move_remove_without_rebuilding():
    scene = motion.PlanningScene("kth", {"a": box((0.05, 0.05, 0.1), (0.7, 0, 0.8))})
    q = scene.full_q(scene.robot.home)
    assert scene.is_valid(q)
    scene.tcp_pose(q)
    sm = scene.scene_model()
    p = sm.data.site_xpos[sm.model.site(scene.robot.flange_site).id].copy()
    model_before = sm.model
    scene.move_object("a", np.array([*(p - [0.7, 0, 0.8]), 1, 0, 0, 0]))
    assert not scene.is_valid(q)  # the box now sits on the flange
    assert scene.scene_model().model is model_before  # moved, not recompiled
    scene.move_object("a", np.eye(4))
    assert scene.is_valid(q)
    scene.add_object("b", box((0.05, 0.05, 0.1), (0.7, 0.2, 0.8)))
    scene.remove_object("b")
    assert scene.object_names == ("a",)


def test_time_parameterisation_respects_limits():
    rng = np.random.default_rng(1)
    path = np.cumsum(rng.normal(0, 0.3, size=(6, 7)), axis=0)
    vmax, amax = np.full(7, 1.0), np.full(7, 2.0)
    for corners in (True, False):
        t, q = time_path(path, vmax, amax, 0.005, corners)
        assert np.allclose(q[0], path[0]) and np.allclose(q[-1], path[-1])
        v = np.diff(q, axis=0) / np.diff(t)[:, None]
        assert np.abs(v).max() <= 1.0 + 1e-6
        if corners:
            a = np.diff(v, axis=0) / np.diff(t)[1:, None]
            assert np.abs(a).max() <= 2.0 * 1.05


def test_grasp_poses_from_candidates():
    from symjax.grasp.candidate_set import Candidates

    c = Candidates(
        approach=np.array([[0, 0, -1.0]]), point=np.array([[0.7, 0, 0.8]]),
        roll=np.zeros(1), preshape=np.array([1], np.int32), distance=np.array([0.1]),
    )  # fmt: skip
    (g,) = motion.grasp_poses(c)
    assert np.allclose(g.pregrasp[0], [0.7, 0, 0.9]) and np.allclose(g.grasp[0], [0.7, 0, 0.8])
    assert np.allclose(g.approach, [0, 0, -1], atol=1e-6)


def test_closing_fingers_are_checked_against_the_clutter():
    """A post where a Barrett finger ends when it closes: clear at the pre-shape, hit while closing;
    with a target between the fingers they stop on it and the post is never reached."""
    from symjax.motion.closing import closing_contacts

    scene = motion.PlanningScene("uji")
    q = scene.full_q(scene.robot.home, "open")
    sm = scene.scene_model()
    d = mujoco.MjData(sm.model)
    closed = q.copy()
    n = scene.robot.n_arm
    closed[n:] = 0.0
    for j, name in enumerate(scene.hand.joint_names):
        if name.endswith("proximal"):
            closed[n + j] = 1.3
    d.qpos[:] = closed
    mujoco.mj_kinematics(sm.model, d)
    tip = d.geom_xpos[sm.model.geom(scene.robot.hand_prefix + "f3_distal").id].copy()
    scene.add_object("post", box((0.02, 0.02, 0.02), tip))
    assert scene.is_valid(q)  # the pre-shape is clear of it
    hits = closing_contacts(scene, q, scene.hand.preshape_index("open"))
    assert any("obj/post" in a + b for a, b, _ in hits), hits
    # A wide target between the fingers stops them before the post.
    p, _ = scene.tcp_pose(q)
    scene.add_object("can", box((0.18, 0.08, 0.06), p + (0.0, 0.0, -0.04)))
    scene.target = "can"
    assert closing_contacts(scene, q, scene.hand.preshape_index("open")) == []


def test_obstacle_margin_applies_to_the_other_objects_only():
    scene = motion.PlanningScene("uji", {"a": box((0.06, 0.06, 0.02), (0.0, 0.0, 0.0))})
    q = scene.full_q(scene.robot.home)
    p, _ = scene.tcp_pose(q)
    # A box 0.2 m below the TCP: farther than 5 mm from the robot, nearer than 0.3 m.
    scene.move_object("a", np.r_[p[:2], p[2] - 0.2, 1.0, 0.0, 0.0, 0.0])
    assert not scene.collisions(q)
    scene.obstacle_margin = 0.3
    near = [x for a, b, x in scene.collisions(q) if "obj/a" in a + b]
    assert near and all(0.005 < x < 0.3 for x in near)
    scene.target = "a"  # the target keeps the plain margin
    assert not scene.collisions(q)


def test_start_check_keeps_the_plain_margin_for_other_objects():
    # An object 7 mm from the hand at home is inside the 1 cm obstacle margin but does not stop
    # the robot from starting there (a pick left the hand 9.4 mm from a neighbour's shape).
    from symjax.motion.pick import _check_start

    scene = motion.PlanningScene("uji", {"a": box((0.06, 0.06, 0.02), (0.0, 0.0, 0.0))})
    q = scene.full_q(scene.robot.home)
    p, _ = scene.tcp_pose(q)
    scene.move_object("a", np.r_[p, 1.0, 0.0, 0.0, 0.0])
    scene.margin = scene.obstacle_margin = 0.05
    d = min(x for a, b, x in scene.collisions(q) if "obj/a" in a + b)  # the box's gap, below
    scene.move_object("a", np.r_[p[:2], p[2] + d - 0.007, 1.0, 0.0, 0.0, 0.0])
    scene.margin, scene.obstacle_margin = 0.005, 0.01
    assert scene.collisions(q)  # inside the obstacle margin ...
    _check_start(scene, None, "open")  # ... but the start is allowed
    scene.obstacle_margin = 0.005
    scene.margin = 0.008
    with pytest.raises(motion.StartInCollisionError):
        _check_start(scene, None, "open")


def test_carrying_keeps_the_plain_clearance_from_the_table():
    # The IK solver reused its ``table`` argument (a clearance in metres) for the table's geom
    # index while an object was held: a 2 m clearance stopped a carrying hand 46 mm above the
    # table (the detection distance) instead of 5 mm, e.g. when setting an object down.
    scene = motion.PlanningScene("uji", {"held": box((0.04, 0.04, 0.04), (0.7, 0.0, 1.05))},
                                 target="held")  # fmt: skip
    cfg = motion.MotionConfig()
    scene.margin = cfg.check_margin
    ik = motion.ArmIK(scene, cfg)
    table = scene.robot.table_height()
    pre = ik.solve(np.array([0.7, 0.0, table + 0.3]), DOWN, scene.full_q(scene.robot.home))
    assert pre.converged
    scene.move_object("held", np.r_[scene.tcp_pose(pre.q)[0], 1.0, 0.0, 0.0, 0.0])
    scene.attach("held", pre.q)
    try:
        path, err, _, col = ik.line(pre.q, np.array([0.7, 0.0, table + 0.05]), DOWN,
                                    avoid=("table",), allow=(("carried", "table"),))  # fmt: skip
        sm = scene.scene_model()
        m, d = sm.model, sm.data
        d.qpos[:] = path[-1]
        mujoco.mj_kinematics(m, d)
        robot = np.concatenate([sm.hand_geoms, sm.arm_geoms])
        gap = min(mujoco.mj_geomDistance(m, d, int(g), int(sm.fixed_geoms[0]), 0.2, None)
                  for g in robot)  # fmt: skip
    finally:
        scene.detach()
    assert not col and err < cfg.cartesian_tolerance, (err, col)
    assert cfg.clearance - 1e-4 <= gap < 0.02
