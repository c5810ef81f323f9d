"""Contact-based grasp quality: force closure and the Ferrari-Canny epsilon (L1), in pure JAX.

A contact is a point on the object and the unit normal along which the finger pushes into the
object. Coulomb friction cones are linearised into ``n_edges`` edge forces of unit normal
component; each edge force ``f`` at contact ``p`` gives a primitive wrench
``(f, (p - c) x f / rho)`` with ``c`` the object's centre of mass and ``rho`` a length that
makes torques comparable to forces (the object's radius). Optionally a soft-finger torsional
friction adds the pure-torque wrenches ``(n, (p - c) x n / rho +- gamma n / rho)``.

The grasp is in force closure when the origin lies strictly inside the convex hull of the
primitive wrenches; the Ferrari-Canny L1 quality (``epsilon``) is the radius of the largest
ball about the origin inside that hull (sum of contact normal forces bounded by 1).

The kernel computes the signed distance ``min_{|u|=1} max_i u . w_i``: positive and equal to
``epsilon`` when the origin is inside, minus the distance from the origin to the hull when it is
outside. The minimum over the 6-D unit sphere is found by annealed smooth-max descent from many
directions, then polished by fitting a hyperplane through the six most active wrenches (the
facet the descent converged to). Every value it tries is an upper bound of the true minimum, so
the result never over-states the quality; it matches a Qhull reference to about 1e-4 of the
wrench scale (``tests/test_quality.py``).
"""

from __future__ import annotations

from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

from symjax import geometry
from symjax.array_types import ArrayLike
from symjax.errors import InvalidInputError, ShapeError

__all__ = [
    "contact_quality",
    "epsilon_l1",
    "force_closure",
    "primitive_wrenches",
    "tangent_basis",
]

_N_START = 2048
_N_DESCENT = 32
_N_ITERS = 200
_N_POLISH = 4
_CLOSURE_TOL = 1e-6


def tangent_basis(n: jax.Array) -> tuple[jax.Array, jax.Array]:
    """Two unit tangents orthogonal to unit ``n`` (3,), each shape (3,)."""
    return geometry.tangent_basis(n, xp=jnp)


def primitive_wrenches(
    pos: jax.Array,
    normal: jax.Array,
    center: jax.Array,
    *,
    friction: float,
    n_edges: int = 8,
    rho: float = 1.0,
    torsion: float = 0.0,
) -> jax.Array:
    """Primitive wrenches of a contact set, shape (K * W, 6).

    Args:
        pos: Contact points on the object, shape (K, 3), metres.
        normal: Unit normals pointing into the object (the direction the finger pushes),
            shape (K, 3).
        center: Torque reference (the object's centre of mass), shape (3,), metres.
        friction: Coulomb coefficient (scalar).
        n_edges: Edges of the linearised friction cone (static int).
        rho: Torque scale, metres: torques are divided by it.
        torsion: Soft-finger torsional friction length (metres, scalar); 0 for point contacts.
            When positive, ``W = n_edges + 2``, else ``W = n_edges``.
    """
    normal = normal / jnp.linalg.norm(normal, axis=-1, keepdims=True)
    t1, t2 = jax.vmap(tangent_basis)(normal)
    ang = 2.0 * jnp.pi * jnp.arange(n_edges) / n_edges
    f = normal[:, None, :] + friction * (
        jnp.cos(ang)[None, :, None] * t1[:, None, :] + jnp.sin(ang)[None, :, None] * t2[:, None, :]
    )  # (K, E, 3)
    r = (pos - center)[:, None, :]
    tau = jnp.cross(jnp.broadcast_to(r, f.shape), f) / rho
    w = jnp.concatenate([f, tau], axis=-1)
    if torsion:
        tn = jnp.cross(r[:, 0], normal) / rho
        spin = torsion * normal / rho
        ws = jnp.stack(
            [jnp.concatenate([normal, tn + spin], -1), jnp.concatenate([normal, tn - spin], -1)],
            axis=1,
        )
        w = jnp.concatenate([w, ws], axis=1)
    return w.reshape(-1, 6)


def _fixed_directions(n: int) -> np.ndarray:
    # Deterministic starts: the 12 signed axes plus quasi-uniform Gaussian directions.
    rng = np.random.default_rng(20110509)
    d = rng.normal(size=(n - 12, 6))
    d = np.concatenate([np.eye(6), -np.eye(6), d])
    return (d / np.linalg.norm(d, axis=1, keepdims=True)).astype(np.float32)


_STARTS = _fixed_directions(_N_START)


def epsilon_l1(wrenches: jax.Array, valid: jax.Array | None = None) -> jax.Array:
    """Signed Ferrari-Canny distance of a wrench set (see the module docstring), scalar.

    Args:
        wrenches: Primitive wrenches, shape (M, 6).
        valid: Which rows count, shape (M,), bool; default all. With no valid row the result
            is ``-inf``.

    Returns:
        ``epsilon`` > 0 when the origin is inside the hull, else minus its distance to the hull.
    """
    w = jnp.asarray(wrenches)
    if valid is None:
        valid = jnp.ones(w.shape[0], dtype=bool)
    any_valid = jnp.any(valid)
    # Invalid rows become copies of a valid one: duplicates leave the hull unchanged, while a
    # zero row would put the origin on it.
    first = w[jnp.argmax(valid)]
    w = jnp.where(valid[:, None], w, first[None, :])
    scale = jnp.maximum(jnp.max(jnp.linalg.norm(w, axis=-1)), 1e-12)
    ws = w / scale

    starts = jnp.asarray(_STARTS, dtype=ws.dtype)
    h0 = jnp.max(starts @ ws.T, axis=-1)
    _, idx = jax.lax.top_k(-h0, _N_DESCENT)
    u0 = starts[idx]

    def descend(u):
        def step(u, k):
            frac = k / (_N_ITERS - 1)
            tau = 0.02 * (1e-4 / 0.02) ** frac  # anneal the smooth max towards the hard max
            lr = 0.3 * (1e-3 / 0.3) ** frac
            s = ws @ u
            g = jax.nn.softmax(s / tau) @ ws
            g = g - jnp.dot(g, u) * u
            u = u - lr * g
            return u / jnp.linalg.norm(u), jnp.max(ws @ u)

        u, hs = jax.lax.scan(step, u, jnp.arange(_N_ITERS, dtype=ws.dtype))
        best = jnp.min(hs)

        # Polish: the six most active wrenches span the facet the descent is heading to; the
        # hyperplane through them gives the next direction. h(u) of any unit u bounds the
        # minimum from above, so every try is safe to keep.
        def polish(carry, _):
            u, best = carry
            _, act = jax.lax.top_k(ws @ u, 6)
            n = jnp.linalg.solve(ws[act], jnp.ones(6))
            nn = jnp.linalg.norm(n)
            ok = jnp.all(jnp.isfinite(n)) & (nn > 1e-9)
            un = jnp.where(ok, n / jnp.where(ok, nn, 1.0), u)
            return (un, jnp.minimum(best, jnp.max(ws @ un))), None

        (_, best), _ = jax.lax.scan(polish, (u, best), None, length=_N_POLISH)
        return best

    h = jnp.min(jax.vmap(descend)(u0))
    h = jnp.minimum(h, jnp.min(h0))
    return jnp.where(any_valid, h * scale, -jnp.inf)


def force_closure(epsilon: jax.Array, tol: float = _CLOSURE_TOL) -> jax.Array:
    """Force closure from the signed epsilon: the origin strictly inside the hull."""
    return epsilon > tol


def contact_quality(
    pos: jax.Array,
    normal: jax.Array,
    valid: jax.Array,
    center: jax.Array,
    *,
    friction: float = 0.5,
    n_edges: int = 8,
    rho: float = 1.0,
    torsion: float = 0.0,
) -> tuple[jax.Array, jax.Array]:
    """Force closure and epsilon of one contact set (``jax.vmap`` it over candidates).

    Args:
        pos: Contact points, shape (K, 3), metres.
        normal: Unit normals into the object, shape (K, 3).
        valid: Which contacts are real, shape (K,), bool.
        center: Object centre of mass, shape (3,), metres.
        friction: Coulomb coefficient of the linearised cones.
        n_edges: Cone edges (static).
        rho: Torque scale, metres (the object's radius).
        torsion: Soft-finger torsional friction length, metres (0: point contacts).

    Returns:
        ``(closure bool scalar, epsilon scalar)``; epsilon is clipped at 0 (no closure).
    """
    w = primitive_wrenches(
        pos, normal, center, friction=friction, n_edges=n_edges, rho=rho, torsion=torsion
    )
    per = w.shape[0] // pos.shape[0]
    eps = epsilon_l1(w, jnp.repeat(valid, per))
    closed = force_closure(eps)
    return closed, jnp.where(closed, eps, 0.0)


def check_contacts(pos: ArrayLike, normal: ArrayLike, center: Any) -> None:
    """Raises a :class:`ShapeError` / :class:`InvalidInputError` for malformed contact arrays."""
    p, n, c = np.asarray(pos), np.asarray(normal), np.asarray(center)
    if p.ndim != 2 or p.shape[-1] != 3 or n.shape != p.shape:
        raise ShapeError(f"pos and normal must both be (K, 3), got {p.shape}, {n.shape}")
    if c.shape != (3,):
        raise ShapeError(f"center must be (3,), got {c.shape}")
    if not (np.all(np.isfinite(p)) and np.all(np.isfinite(n))):
        raise InvalidInputError("contact arrays contain NaN or inf")
