"""A part's footprint on the table: the projection against world points, circles, extents and
the distance to a hull against simple numpy references."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from symjax.geometry import pixel_rays, tangent_basis
from symjax.perception.footprint import (
    fit_circle,
    hull_distance,
    principal_extents,
    round_footprint,
    table_footprint,
)


def test_table_footprint_is_the_world_points_in_the_table_basis():
    rng = np.random.default_rng(5)
    H, W = 12, 16
    K = np.array([[500.0, 0.0, W / 2], [0.0, 500.0, H / 2], [0.0, 0.0, 1.0]])
    rays = pixel_rays(K, H, W).astype(np.float32)
    depth = rng.uniform(0.5, 1.0, (H, W)).astype(np.float32)
    labels = rng.integers(-1, 3, (H, W)).astype(np.int32)
    a = rng.normal(size=3)
    R = np.linalg.qr(rng.normal(size=(3, 3)))[0]
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = R * np.sign(np.linalg.det(R)), a
    n = rng.normal(size=3)
    n /= np.linalg.norm(n)
    world = (rays.astype(np.float64) * depth[..., None]) @ T[:3, :3].T + T[:3, 3]
    want = world @ np.stack(tangent_basis(n), 1)
    # A crop, as the segmentation passes it: not contiguous.
    sl = (slice(1, H - 1), slice(2, W - 1))
    got = table_footprint(labels[sl], rays[sl], depth[sl], T, n)
    assert got.shape == (H - 2, W - 3, 2)
    on = labels[sl] >= 0
    np.testing.assert_allclose(got[on], want[sl][on], atol=1e-6)
    assert not got[~on].any()


@settings(max_examples=25, deadline=None)
@given(st.floats(-1, 1), st.floats(-1, 1), st.floats(0.01, 0.5), st.floats(0.3, 6.0))
def test_fit_circle_recovers_a_circle_from_an_arc(cx, cy, r, span):
    t = np.linspace(0.0, span, 50)
    pts = np.stack([cx + r * np.cos(t), cy + r * np.sin(t)], axis=1)
    c, radius = fit_circle(pts)
    np.testing.assert_allclose(c, [cx, cy], atol=1e-6 + 1e-5 * r / span**2)
    np.testing.assert_allclose(radius, r, rtol=1e-5 / span**2, atol=1e-7)


def test_a_wall_arc_is_round_a_box_corner_and_a_filled_square_are_not():
    t = np.linspace(0.3, 2.8, 400)  # (a wall seen over 143 deg)
    arc = np.stack([0.033 * np.cos(t), 0.033 * np.sin(t)], axis=1)
    got = round_footprint(arc)
    assert got is not None and abs(got[1] - 0.033) < 1e-6
    s = np.linspace(0.0, 0.06, 200)
    corner = np.concatenate([np.stack([s, 0 * s], 1), np.stack([0 * s, s], 1)])
    assert round_footprint(corner) is None
    g = np.stack(np.meshgrid(np.linspace(0, 0.06, 20), np.linspace(0, 0.06, 20)), -1)
    assert round_footprint(g.reshape(-1, 2)) is None


def test_principal_extents_of_a_turned_rectangle():
    rng = np.random.default_rng(3)
    pts = rng.uniform([-0.06, -0.02], [0.06, 0.02], (4000, 2))
    a = 0.7
    R = np.array([[np.cos(a), -np.sin(a)], [np.sin(a), np.cos(a)]])
    major, minor = principal_extents(pts @ R.T + 0.3)
    # The robust extents (2nd to 98th percentile) of a uniform 12 x 4 cm rectangle.
    np.testing.assert_allclose([major, minor], [0.96 * 0.12, 0.96 * 0.04], rtol=0.03)


@settings(max_examples=25, deadline=None)
@given(st.integers(0, 2**31 - 1), st.booleans())
def test_hull_distance_to_a_square_against_numpy(seed, clockwise):
    rng = np.random.default_rng(seed)
    square = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
    hull = square[::-1] if clockwise else square
    pts = rng.uniform(-1.0, 2.0, (200, 2))
    got = hull_distance(hull, pts)
    inside = np.all((pts > 0) & (pts < 1), axis=1)
    exact = np.min(np.concatenate([pts, 1 - pts], axis=1), axis=1)
    np.testing.assert_allclose(got[inside], exact[inside], atol=1e-12)
    # Outside: negative, and no farther than the true gap to the square.
    gap = np.linalg.norm(pts - np.clip(pts, 0, 1), axis=1)
    assert (got[~inside] <= 1e-12).all() and (-got[~inside] <= gap[~inside] + 1e-12).all()
