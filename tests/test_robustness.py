"""Grasp robustness to the hand's pose: perturbed candidates against a numpy reference, the
robustness score against plain C-MuJoCo rollouts, and its place in the ranking."""

from __future__ import annotations

import math

import numpy as np
import pytest
import trimesh
from test_simulate import SMALL, outcomes

from symjax import configs, grasp, hands
from symjax.errors import ConfigError, ShapeError
from symjax.grasp import Candidates, RobustnessConfig, rank
from symjax.grasp.robustness import perturbed_candidates, pose_robustness


def _candidates(n: int, seed: int = 0) -> Candidates:
    rng = np.random.default_rng(seed)
    a = rng.normal(size=(n, 3))
    return Candidates(
        approach=(a / np.linalg.norm(a, axis=1, keepdims=True)).astype(np.float32),
        point=rng.uniform(-0.1, 0.1, (n, 3)).astype(np.float32),
        roll=rng.uniform(-np.pi, np.pi, n).astype(np.float32),
        preshape=np.full(n, 2, np.int32),
        distance=np.full(n, 0.05, np.float32),
    )


@pytest.mark.parametrize("n", [1, 3, 8])
def test_perturbed_poses_move_along_the_hand_axes(n):
    c = _candidates(n)
    cfg = RobustnessConfig(enabled=True, shift=0.01, roll_deg=15.0)
    p = perturbed_candidates(c, cfg)
    assert len(p) == cfg.n_poses * n == 6 * n
    pt = np.asarray(p.point, np.float64).reshape(6, n, 3)
    roll = np.asarray(p.roll, np.float64).reshape(6, n)
    for k, col in enumerate(c.frames().transpose(2, 0, 1)[:2]):  # closing axis, then y
        for s, sign in enumerate((1.0, -1.0)):
            d = pt[2 * k + s] - np.asarray(c.point, np.float64)
            np.testing.assert_allclose(d, sign * 0.01 * col, atol=1e-7)
            # A shift keeps the approach: the hand still arrives along the same direction.
            assert np.all(np.abs(d @ np.asarray(c.approach, np.float64).T).diagonal() < 1e-6)
    np.testing.assert_allclose(roll[4] - c.roll, math.radians(15.0), atol=1e-6)
    np.testing.assert_allclose(roll[5] - c.roll, -math.radians(15.0), atol=1e-6)
    np.testing.assert_array_equal(np.asarray(p.approach).reshape(6, n, 3)[3], c.approach)
    assert RobustnessConfig(enabled=True, roll_deg=0.0).n_poses == 4
    assert RobustnessConfig(enabled=True, shift=0.0).n_poses == 2


def test_only_stable_grasps_are_rolled_out_again():
    c = _candidates(5, seed=1)
    ok = np.array([True, False, True, True, False])
    cfg = RobustnessConfig(enabled=True)
    sizes = []

    def holds(points):
        # Holds while the perturbed point does not move 0.1 mm or more towards -x.
        return np.asarray(points, np.float64)[:, 0] > np.tile(np.asarray(c.point)[ok, 0], 6) - 1e-4

    def rollout(batch):
        sizes.append(len(batch))
        return holds(batch.point)

    r = pose_robustness(c, ok, rollout, cfg)
    assert sizes == [6 * 3]
    held = holds(perturbed_candidates(c.take(np.flatnonzero(ok)), cfg).point).reshape(6, 3)
    assert 0 < held.sum() < held.size
    np.testing.assert_allclose(r[ok], (1 + held.sum(axis=0)) / 7)
    assert np.all(r[~ok] == 0)
    assert np.all(pose_robustness(c, np.zeros(5, bool), rollout, cfg) == 0) and sizes == [18]
    with pytest.raises(ShapeError):
        pose_robustness(c, ok[:3], rollout, cfg)
    # At most max_grasps stable grasps, the first in the given order: 3 then 2 (not 0).
    sizes.clear()
    capped = RobustnessConfig(enabled=True, max_grasps=2)
    r2 = pose_robustness(c, ok, lambda b: np.ones(len(b), bool), capped, order=[4, 3, 1, 2, 0])
    assert sizes == [] and np.flatnonzero(r2).tolist() == [2, 3] and np.all(r2[[2, 3]] == 1)


def test_rank_puts_robustness_right_after_success():
    o = outcomes([True, True, False, True], [True] * 4, [0.3, 0.1, 0.9, 0.2], [3] * 4)
    np.testing.assert_array_equal(rank(o), [0, 3, 1, 2])
    # The failure (2) stays last however robust; among successes, robustness before epsilon.
    np.testing.assert_array_equal(rank(o, robustness=[0.5, 1.0, 1.0, 0.5]), [1, 0, 3, 2])


def test_plan_robustness_matches_plain_rollouts_of_the_perturbed_poses():
    box = trimesh.creation.box([0.05, 0.08, 0.12])
    box.apply_translation([0.5, 0.1, 0.06])
    v, f = np.asarray(box.vertices), np.asarray(box.faces)
    hand = hands.load("barrett")
    # Shifts of 4 cm on a 5 x 8 cm box: some grasps hold wherever the hand lands, some do not.
    cfg = RobustnessConfig(enabled=True, shift=0.04, roll_deg=40.0)
    p = grasp.plan((v, f), hand, "uji", hulls=[(v, f)], candidates=SMALL, backend="mujoco",
                   robustness=cfg)  # fmt: skip
    plain = grasp.plan((v, f), hand, "uji", hulls=[(v, f)], candidates=SMALL, backend="mujoco")
    assert plain.robustness is None and "robustness" in p.seconds
    c = p.candidate_set.candidates
    ok = np.asarray(plain.outcomes.success, bool)[np.argsort(plain.order)]  # generator order
    # The cap: the first max_grasps stable grasps of the one-rollout ranking.
    held = plain.order[np.asarray(plain.outcomes.success, bool)][: cfg.max_grasps]
    scene = grasp.build_scene([(v, f)], hand)
    moved = grasp.simulate(None, perturbed_candidates(c.take(held), cfg), hand, backend="mujoco",
                           scene=scene)  # fmt: skip
    want = np.zeros(len(c))
    want[held] = (1 + np.asarray(moved.success, float).reshape(6, -1).sum(axis=0)) / 7
    np.testing.assert_allclose(p.robustness, want[p.order])
    np.testing.assert_array_equal(p.order, rank(plain.outcomes.take(np.argsort(plain.order)),
                                                robustness=want))  # fmt: skip
    assert ok.sum() > cfg.max_grasps  # the cap matters here
    assert 0 < ok.sum() and np.any((want > 0) & (want < 1))  # some grasps hinge on the pose


@pytest.mark.parametrize(
    "kw, words",
    [
        ({"shift": -0.01}, ["shift", "-0.01", "[0, 0.1]"]),
        ({"roll_deg": 120.0}, ["roll_deg", "120.0", "[0, 90]"]),
        ({"enabled": True, "shift": 0.0, "roll_deg": 0.0}, ["no pose to try"]),
        ({"max_grasps": 0}, ["max_grasps", ">= 1", "0"]),
    ],
)
def test_config_rejects_bad_values(kw, words):
    with pytest.raises(ConfigError) as e:
        RobustnessConfig(**kw)
    assert all(w in str(e.value) for w in words)


def test_presets_rank_the_study_by_robustness_and_leave_the_paper_off():
    study, cycle = configs.load("study"), configs.load("cycle")
    assert study.robustness.enabled and study.candidates == cycle.candidates
    assert not configs.load("default").robustness.enabled and not cycle.robustness.enabled
