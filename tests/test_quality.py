"""Force closure and Ferrari-Canny epsilon: Qhull reference on random sets, and known grasps."""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from scipy.spatial import ConvexHull

from symjax.grasp import quality as q

MU, EDGES, RHO = 0.5, 8, 0.05


def _reference(w: np.ndarray) -> float:
    """Qhull: min over facets of the origin's distance (positive inside); <= 0 when outside."""
    h = ConvexHull(np.asarray(w, np.float64))
    return float(-h.equations[:, -1].max())


@pytest.fixture(scope="module")
def random_sets():
    """200 random sets of 3-5 contacts on a 5 cm sphere with noisy inward normals."""
    rng = np.random.default_rng(0)
    P, N, V = [], [], []
    for _ in range(200):
        k = int(rng.integers(3, 6))
        d = rng.normal(size=(5, 3))
        d /= np.linalg.norm(d, axis=1, keepdims=True)
        n = -d + 0.3 * rng.normal(size=(5, 3))
        n /= np.linalg.norm(n, axis=1, keepdims=True)
        P.append(RHO * d)
        N.append(n)
        V.append(np.arange(5) < k)
    return np.array(P, np.float32), np.array(N, np.float32), np.array(V)


@pytest.fixture(scope="module")
def kernel():
    def one(p, n, v):
        return q.contact_quality(p, n, v, jnp.zeros(3), friction=MU, n_edges=EDGES, rho=RHO)

    return jax.jit(jax.vmap(one))


def test_closure_and_epsilon_match_qhull(random_sets, kernel):
    P, N, V = random_sets
    closed, eps = (np.asarray(x) for x in kernel(P, N, V))
    W = jax.vmap(
        lambda p, n: q.primitive_wrenches(p, n, jnp.zeros(3), friction=MU, n_edges=EDGES, rho=RHO)
    )(P, N)
    W = np.asarray(W)
    ref = np.array([_reference(w[: EDGES * v.sum()]) for w, v in zip(W, V, strict=True)])
    inside = ref > 1e-6
    assert 0.2 < inside.mean() < 0.9  # both labels occur
    agree = (closed == inside).mean()
    assert agree >= 0.98, agree
    both = inside & closed
    # The kernel minimises an upper bound: it can overshoot a missed facet, never undershoot.
    assert np.all(eps[both] >= ref[both] - 1e-5)
    rel = np.abs(eps[both] - ref[both]) / ref[both]
    assert np.median(rel) < 1e-3, np.median(rel)
    assert np.percentile(rel, 90) < 0.03, np.percentile(rel, 90)
    assert np.all(eps[~closed] == 0.0)


def test_signed_distance_outside_matches_min_norm_point():
    """Origin outside the hull: the kernel returns minus its distance to the hull."""
    rng = np.random.default_rng(1)
    w = rng.normal(size=(20, 6)) * 0.3 + np.array([1.0, 0.5, 0, 0, 0, 0])
    # Reference distance from the origin to conv(w): a small QP by projected gradient.
    lam = np.full(20, 1 / 20)
    for _ in range(20000):
        x = lam @ w
        lam = lam - 0.01 * (w @ x)
        # projection onto the simplex
        u = np.sort(lam)[::-1]
        css = np.cumsum(u) - 1
        r = np.nonzero(u - css / np.arange(1, 21) > 0)[0][-1]
        lam = np.maximum(lam - css[r] / (r + 1), 0)
    dist = np.linalg.norm(lam @ w)
    got = float(q.epsilon_l1(jnp.asarray(w, jnp.float32)))
    assert got < 0
    assert abs(-got - dist) < 1e-3 * max(dist, 1.0), (got, dist)


def _patch(center, normal, tangent, half=0.01):
    """Four contact points of a square finger pad on a face."""
    b = np.cross(normal, tangent)
    pts = [center + half * (sx * tangent + sy * b) for sx in (-1, 1) for sy in (-1, 1)]
    return np.array(pts), np.repeat(np.asarray(normal, float)[None], 4, axis=0)


def test_known_box_grasps():
    """Two opposing finger pads on a 6 cm box: closure; both pads on the same face: none."""
    ex, ey = np.array([1.0, 0, 0]), np.array([0, 1.0, 0])
    left = _patch(np.array([-0.03, 0, 0]), ex, ey)  # pushes +x on the -x face
    right = _patch(np.array([0.03, 0, 0]), -ex, ey)
    same = _patch(np.array([-0.03, 0.0, 0.015]), ex, ey)

    def quality(parts, mu=MU):
        p = np.concatenate([x[0] for x in parts])
        n = np.concatenate([x[1] for x in parts])
        c, e = q.contact_quality(
            jnp.asarray(p), jnp.asarray(n), jnp.ones(len(p), bool), jnp.zeros(3),
            friction=mu, n_edges=EDGES, rho=RHO,
        )  # fmt: skip
        return bool(c), float(e)

    c, e = quality([left, right])
    assert c and e > 0.01
    assert not quality([left, same])[0]
    assert not quality([left, right], mu=0.0)[0]  # frictionless pads cannot hold a box
    # Two point contacts cannot resist torque about the line through them...
    pts = np.array([[-0.03, 0, 0], [0.03, 0, 0]])
    nrm = np.array([ex, -ex])
    args = (jnp.asarray(pts), jnp.asarray(nrm), jnp.ones(2, bool), jnp.zeros(3))
    assert not bool(q.contact_quality(*args, friction=MU, rho=RHO)[0])
    # ...unless soft fingers add torsional friction.
    assert bool(q.contact_quality(*args, friction=MU, rho=RHO, torsion=0.01)[0])


def test_masked_contacts_are_ignored(random_sets):
    P, N, V = random_sets
    i = int(np.flatnonzero(V.sum(1) == 3)[0])
    base = q.contact_quality(P[i], N[i], V[i], jnp.zeros(3), friction=MU, rho=RHO)
    garbage = P[i].copy()
    garbage[~V[i]] = 10.0  # far away; must not matter when masked
    other = q.contact_quality(garbage, N[i], V[i], jnp.zeros(3), friction=MU, rho=RHO)
    assert bool(base[0]) == bool(other[0])
    np.testing.assert_allclose(float(base[1]), float(other[1]), rtol=1e-6)
    none = q.contact_quality(P[i], N[i], np.zeros(5, bool), jnp.zeros(3), friction=MU, rho=RHO)
    assert not bool(none[0]) and float(none[1]) == 0.0


def test_bad_contacts_raise():
    from symjax.errors import InvalidInputError, ShapeError

    with pytest.raises(ShapeError):
        q.check_contacts(np.zeros((3, 2)), np.zeros((3, 2)), np.zeros(3))
    with pytest.raises(InvalidInputError):
        q.check_contacts(np.full((2, 3), np.nan), np.ones((2, 3)), np.zeros(3))
