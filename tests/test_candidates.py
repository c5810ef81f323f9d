"""Grasp candidate generators: unit approaches, counts, reproducibility and the drop checks."""

from __future__ import annotations

import jax
import numpy as np
import pytest
import trimesh

from symjax import grasp, hands
from symjax.errors import ConfigError, InvalidInputError, ShapeError, UnknownNameError
from symjax.table import TablePlane

TABLE = TablePlane.horizontal(0.0)


@pytest.fixture(scope="module")
def bottle():
    """A 7 cm x 20 cm cylinder standing on the table at (0.6, 0)."""
    m = trimesh.creation.cylinder(0.035, 0.2, sections=32)
    m.apply_translation([0.6, 0.0, 0.1])
    return np.asarray(m.vertices), np.asarray(m.faces)


@pytest.fixture(scope="module")
def box_lying():
    """A 16 x 6 x 5 cm box lying along x on the table."""
    m = trimesh.creation.box([0.16, 0.06, 0.05])
    m.apply_translation([0.5, 0.1, 0.025])
    return np.asarray(m.vertices), np.asarray(m.faces)


@pytest.mark.parametrize("method", grasp.METHODS)
def test_unit_approaches_and_reproducible(method, bottle):
    a = grasp.generate(bottle, method, table=TABLE, seed=3)
    b = grasp.generate(bottle, method, table=TABLE, seed=3)
    c = a.candidates
    assert len(a) > 0
    np.testing.assert_allclose(np.linalg.norm(c.approach, axis=1), 1.0, atol=1e-5)
    for x, y in zip(
        jax.tree_util.tree_leaves(c), jax.tree_util.tree_leaves(b.candidates), strict=True
    ):
        np.testing.assert_array_equal(x, y)
    # The frame's z column is the approach; frames are rotations.
    F = np.asarray(c.frames())
    np.testing.assert_allclose(F[..., 2], c.approach, atol=1e-5)
    np.testing.assert_allclose(np.einsum("nij,nik->njk", F, F), np.broadcast_to(np.eye(3), F.shape),
                               atol=1e-5)  # fmt: skip
    assert np.all((c.distance >= 0) & (c.distance <= 0.2))
    assert a.n_generated == len(a) + a.n_dropped_table + a.n_dropped_object


def test_openrave_seed_changes_samples_and_normals_match(bottle):
    a = grasp.generate(bottle, "openrave", seed=0).candidates
    b = grasp.generate(bottle, "openrave", seed=1).candidates
    assert not np.allclose(a.point[:10], b.point[:10])
    # Points lie on the cylinder; side hits approach radially inward, cap hits vertically.
    p, ap = a.point, a.approach
    r = np.hypot(p[:, 0] - 0.6, p[:, 1])
    side = (p[:, 2] > 0.005) & (p[:, 2] < 0.195)
    assert np.all(r < 0.0351) and side.any()
    radial = -np.c_[p[side, 0] - 0.6, p[side, 1]] / r[side, None]
    assert np.all(np.einsum("ij,ij->i", ap[side, :2], radial) > 0.95)
    # Bounding-box rays from under the table give approaches from below: all dropped.
    with_table = grasp.generate(bottle, "openrave", table=TABLE, seed=0)
    assert with_table.n_dropped_table > 0 and np.all(with_table.candidates.approach[:, 2] < 0.5)


@pytest.mark.parametrize("n", [5, 8, 10])
def test_kth_counts_circle_and_roll(n, box_lying):
    cfg = grasp.CandidateConfig(n_approach=n, distances=(0.05, 0.1, 0.2))
    gp = np.array([[0.5, 0.07, 0.025], [0.5, 0.13, 0.025]])
    s = grasp.generate(box_lying, "kth", config=cfg, grasp_points=gp)
    assert s.n_generated == n * 3 and s.n_missed == 0
    c = s.candidates
    u = np.array([0.0, 1.0, 0.0])
    # Approaches lie on the circle normal to the grasp-point line, over the upper half.
    np.testing.assert_allclose(c.approach @ u, 0.0, atol=1e-6)
    assert np.all(c.approach[:, 2] <= 1e-6)
    # Nothing is dropped here (no table; the stand-in palm stays outside the box), so the
    # first and last approaches are the semicircle's two ends.
    assert len(c) == 3 * n
    ang = np.degrees(np.arccos(np.clip(c.approach[0] @ c.approach[-1], -1, 1)))
    assert ang == pytest.approx(180.0, abs=1e-3)
    # The closing axis (frame x) is aligned with the grasp-point line.
    x = np.asarray(c.frames())[..., 0]
    np.testing.assert_allclose(np.abs(x @ u), 1.0, atol=1e-5)
    np.testing.assert_allclose(c.point, np.broadcast_to(gp.mean(0), c.point.shape), atol=1e-6)


def test_kth_default_grasp_points_across_width(box_lying):
    g = grasp.kth_grasp_points(box_lying)
    # Across the 6 cm width (y), at the box's centroid.
    np.testing.assert_allclose(sorted(g[:, 1]), [0.07, 0.13], atol=1e-4)
    np.testing.assert_allclose(g[:, 0], 0.5, atol=1e-4)


def test_uji_two_perpendicular_circles(box_lying):
    cfg = grasp.CandidateConfig(n_approach=6, distances=(0.1,))
    s = grasp.generate(box_lying, "uji", config=cfg)
    assert s.n_generated == 12
    c = s.candidates
    assert len(c) == 12  # from 10 cm nothing starts inside the lying box or the table
    ea = np.array([1.0, 0, 0])  # major axis of the lying box
    first, second = c.approach[:6], c.approach[6:]
    np.testing.assert_allclose(first @ ea, 0, atol=1e-5)  # circle normal to e_a
    n2 = np.cross(second[0], second[-1])
    n2 /= np.linalg.norm(n2)
    np.testing.assert_allclose(second @ n2, 0, atol=1e-5)
    assert abs(n2 @ ea) < 1e-5  # the second circle contains e_a: perpendicular to the first
    # Closing axis across the major axis, points at the centroid.
    x = np.asarray(c.frames())[..., 0]
    np.testing.assert_allclose(x @ ea, 0, atol=1e-5)
    np.testing.assert_allclose(c.point, np.broadcast_to([0.5, 0.1, 0.025], c.point.shape),
                               atol=1e-5)  # fmt: skip


def test_drops_are_counted_with_a_hand(bottle):
    h = hands.load("sdh")
    cfg = grasp.CandidateConfig(distances=(0.0, 0.2))
    s = grasp.generate(bottle, "uji", config=cfg, table=TABLE, hand=h)
    assert s.n_generated == 2 * 8 * 2
    assert s.n_dropped_table + s.n_dropped_object > 0
    assert len(s) == s.n_generated - s.n_dropped_table - s.n_dropped_object
    # Every kept start pose has every hand probe above the table and outside the bottle.
    c = s.candidates
    probes = hands.probe_points(h, "pinch")
    world = c.start_positions()[:, None] + np.einsum("nij,kj->nki", np.asarray(c.frames()), probes)
    assert np.all(world[..., 2] >= -1e-6)
    assert not grasp.inside_mesh(world.reshape(-1, 3), bottle).any()


def test_inside_mesh_and_rays(bottle):
    inside = grasp.inside_mesh(
        [[0.6, 0, 0.1], [0.6, 0, 0.25], [0.64, 0, 0.1], [0.62, 0, 0.1]], bottle
    )
    assert inside.tolist() == [True, False, False, True]
    tri = bottle[0][bottle[1]]
    t, i = grasp.ray_mesh(np.array([0.0, 0, 0.1]), np.array([1.0, 0, 0]), tri)
    assert float(t) == pytest.approx(0.565, abs=1e-3) and int(i) >= 0


def test_bad_input():
    with pytest.raises(UnknownNameError, match="kth.*openrave.*uji"):
        grasp.generate((np.zeros((4, 3)), np.zeros((4, 3), int)), "gpd")
    with pytest.raises(ShapeError):
        grasp.generate((np.zeros((4, 2)), np.zeros((4, 3), int)), "kth")
    with pytest.raises(ConfigError):
        grasp.CandidateConfig(distances=(-0.1,))


def test_candidates_slice_take_and_concatenate(bottle):
    c = grasp.generate(bottle, "uji", table=TABLE).candidates
    n = len(c)
    head, tail = c[:5], c[5:]
    assert len(head) == 5 and len(tail) == n - 5
    both = grasp.Candidates.concatenate([head, tail])
    for a, b in zip(jax.tree_util.tree_leaves(both), jax.tree_util.tree_leaves(c), strict=True):
        np.testing.assert_array_equal(a, b)
    picked = c.take([3, 0, 3])
    np.testing.assert_array_equal(picked.point, np.asarray(c.point)[[3, 0, 3]])
    mask = np.zeros(n, bool)
    mask[[1, 2]] = True
    np.testing.assert_array_equal(c.take(mask).roll, np.asarray(c.roll)[[1, 2]])
    assert len(c[2]) == 1
    with pytest.raises(ShapeError, match="mask"):
        c.take(np.ones(n + 1, bool))
    with pytest.raises(InvalidInputError, match="out of range"):
        c.take([n])
    with pytest.raises(InvalidInputError, match="non-empty list"):
        grasp.Candidates.concatenate([])
