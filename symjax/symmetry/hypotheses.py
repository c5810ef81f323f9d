"""Plane hypotheses of one view: Eq. 1's initial axis, the box axis, the n x m grid and its
coarse-to-fine refinement, scored and reduced to the best plane (Eq. 4).
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np

from symjax.symmetry.config import SymmetryConfig
from symjax.symmetry.result import SymmetryResult
from symjax.symmetry.scoring import _dot, point_terms, reflect, score_planes
from symjax.symmetry.view import ViewArrays

__all__ = ["mirror_view", "search_view"]

SAMPLE_POINTS = 4096


def _initial_plane(view: ViewArrays):
    """Centroid, initial axis s (Eq. 1), base plane normal m0 (away from camera), extent L."""
    n = view.table_normal
    w = view.valid.astype(jnp.float32)
    cnt = jnp.maximum(w.sum(), 1.0)
    # Coordinates as rows (3, N): XLA:CPU vectorises along the long axis (3x faster than (N, 3)).
    p = view.points.T
    c = _dot(p, w) / cnt
    d = p - c[:, None]
    d = d - n[:, None] * _dot(n, d)[None, :]  # projection onto the table plane
    # Entry by entry as products with the weights: the (3, N) x (N, 3) product runs slower.
    cov = jnp.stack([jnp.stack([_dot(d[i] * d[j], w) for j in range(3)]) for i in range(3)]) / cnt
    _, vecs = jnp.linalg.eigh(cov)
    e_a, e_b = vecs[:, 2], vecs[:, 1]  # major, minor in-plane eigenvectors
    v = view.t_wc - c  # inverse viewing direction
    v = v - (v @ n) * n
    v = v / jnp.maximum(jnp.linalg.norm(v), 1e-9)
    s = jnp.where(jnp.abs(e_a @ v) <= jnp.abs(e_b @ v), e_a, e_b)
    m0 = jnp.cross(n, s)
    m0 = m0 / jnp.maximum(jnp.linalg.norm(m0), 1e-9)
    m0 = jnp.where(m0 @ v > 0, -m0, m0)
    s = jnp.cross(m0, n)  # re-orthogonalised, consistent handedness

    lo, hi = _percentiles(jnp.stack([e_a, e_b]) @ d[:, _valid_sample(view.valid)], 2.0, 98.0)
    L = jnp.max(hi - lo)
    return c, s, m0, L


def _percentiles(x, low: float, high: float):
    """``jnp.percentile(x, [low, high], axis=-1)`` (linear interpolation) for rows x (R, M).

    One sort of the rows as int32 keys (the float bits, negatives flipped, order the same):
    XLA:CPU sorts integers 4x faster than floats with their NaN-aware comparator (a tenth of
    the paper's search went to the float sort). The interpolation is jnp's (equal to float32
    rounding).
    """
    m = x.shape[-1]

    def at(q: float):
        pos = np.float32(np.float32(q) / np.float32(100.0)) * np.float32(m - 1)
        i = int(np.floor(pos))
        hw = np.float32(pos - np.float32(i))
        return i, min(int(np.ceil(pos)), m - 1), hw, np.float32(1.0) - hw

    bits = jax.lax.bitcast_convert_type(x, jnp.int32)
    keys = jnp.where(bits < 0, bits ^ 0x7FFFFFFF, bits)
    srt = jax.lax.sort(keys, dimension=x.ndim - 1)
    srt = jax.lax.bitcast_convert_type(jnp.where(srt < 0, srt ^ 0x7FFFFFFF, srt), x.dtype)
    out = []
    for q in (low, high):
        i, j, hw, lw = at(q)
        out.append(srt[..., i] * lw + srt[..., j] * hw)
    return out[0], out[1]


def _valid_sample(valid, size: int = SAMPLE_POINTS):
    """Indices (size,) of valid points spread evenly over them (repeats when fewer).

    The extent and the box orientation only need the shape of the cloud: a fixed-size sample
    keeps their sorts and sweeps cheap for 40,000-point views.
    """
    size = min(size, valid.shape[0])
    count = valid.sum()
    n = jnp.maximum(count, 1)
    want = (jnp.arange(size) * n) // size  # ranks among the valid points

    def scattered():
        rank = jnp.cumsum(valid.astype(jnp.int32))
        return jnp.searchsorted(rank, want + 1)

    # Packed views hold their valid points first (padding after): the rank is the index, and
    # the binary search (a loop of 16 steps, a tenth of the paper's search) is not needed.
    prefix = jnp.all(valid == (jnp.arange(valid.shape[0]) < count))
    idx = jax.lax.cond(prefix, lambda: want.astype(jnp.int32), scattered)
    return jnp.clip(idx, 0, valid.shape[0] - 1)


def _box_angle(view: ViewArrays, c, m0, side, n_sweep: int = 90):
    """Orientation (radians, relative to m0) of the minimum-area rectangle bounding the
    table-projected cloud, by a sweep over [0, 90) deg (an edge direction is its normal), and
    the ratio of the largest to that smallest area over the sweep (how box-like the cloud is)."""
    d = view.points[_valid_sample(view.valid)] - c[None, :]
    x, y = d @ m0, d @ side
    th = jnp.arange(n_sweep) * (jnp.pi / 2 / n_sweep)

    def area(t):
        a = jnp.cos(t) * x + jnp.sin(t) * y
        b = -jnp.sin(t) * x + jnp.cos(t) * y
        return (a.max() - a.min()) * (b.max() - b.min())

    areas = jax.vmap(area)(th)
    return th[jnp.argmin(areas)], areas.max() / jnp.maximum(areas.min(), 1e-12)


def _wrap(phi):
    """Angle of a plane normal wrapped to [-pi/2, pi/2): the same plane, normal away from camera."""
    return jnp.mod(phi + jnp.pi / 2, jnp.pi) - jnp.pi / 2


def _plane_grid(n, m0, c, angles, shifts):
    """Normals (A*S, 3) and offsets (A*S,) of the grid of rotated and shifted planes."""
    side = jnp.cross(n, m0)
    normals = jnp.cos(angles)[:, None] * m0[None, :] + jnp.sin(angles)[:, None] * side[None, :]
    offsets = (normals @ c)[:, None] + shifts[None, :]  # (A, S)
    S = shifts.shape[0]
    return jnp.repeat(normals, S, axis=0), offsets.reshape(-1)


def mirror_view(view: ViewArrays, normal, offset, config: SymmetryConfig):
    """The view's points mirrored across one plane, which of them the completion keeps (not in
    front of an observed surface) and their plausibility (traced).

    Args:
        view: One packed view, N points.
        normal: (3,) unit plane normal; offset: () the plane's offset, metres.
        config: The vote's tolerance and the plausibility scales.

    Returns:
        ``(mirrored (N, 3), keep (N,) bool, plausibility (N,) in [0, 1], 0 for invalid points)``.
    """
    mirrored = reflect(view.points, normal, offset)
    delta1, delta2, _ = point_terms(view, mirrored, config)
    keep = view.valid & (delta2 <= 0.0)
    plaus = jnp.exp(-delta1 / config.plausibility_px**2) * jnp.exp(
        -delta2 / config.plausibility_depth
    )
    return mirrored, keep, jnp.where(view.valid, plaus, 0.0)


def search_view(
    view: ViewArrays, config: SymmetryConfig, gate, chunk_planes: int = 256, occluded=None
) -> SymmetryResult:
    """The whole search for one view (traced; jit and vmap are applied by the callers).

    ``gate`` and ``occluded`` are the unbatched scalars of :func:`score_planes` (which reads
    the view's own flag when ``occluded`` is None); ``chunk_planes`` its chunk size
    (:attr:`symjax.execution.ExecutionConfig.symmetry_chunk_hypotheses`).
    """
    n = view.table_normal
    c, s, m0, L = _initial_plane(view)
    side = jnp.cross(n, m0)
    A, S = config.n_angles, config.n_shifts
    unit_a = jnp.linspace(-1.0, 1.0, A) if A > 1 else jnp.zeros(1)
    unit_s = jnp.linspace(0.0, 1.0, S) if S > 1 else jnp.full(1, 0.5)

    starts = [jnp.float32(0.0)]
    fans = [jnp.float32(1.0)]
    if config.init == "eigen+box":
        # Of the rectangle's two axes keep, as Eq. 1 does among the eigenvectors, the plane whose
        # normal is closest to the viewing direction: the other one maps the visible surface
        # onto itself, scores well and completes nothing behind the object.
        away = c - view.t_wc
        view_angle = jnp.arctan2(away @ side, away @ m0)
        box, rectangularity = _box_angle(view, c, m0, side)
        a0, a1 = _wrap(box), _wrap(box + jnp.pi / 2)
        d0, d1 = jnp.abs(_wrap(a0 - view_angle)), jnp.abs(_wrap(a1 - view_angle))
        starts.append(jnp.where(d0 <= d1, a0, a1))
        box_like = rectangularity > config.box_rectangularity
        fans.append(jnp.where(box_like, jnp.float32(config.box_fan), jnp.float32(1.0)))
        if config.box_axes == 2:
            starts.append(jnp.where(d0 <= d1, a1, a0))
            fans.append(fans[-1])
    starts = jnp.stack(starts)
    fans = jnp.stack(fans)

    # Level 0: the paper's fan of n x m hypotheses around every initial axis, one vmap.
    angles0 = starts[:, None] + (unit_a * config.angle_range)[None, :] * fans[:, None]
    shifts0 = (config.shift_min + unit_s * (config.shift_max - config.shift_min)) * L  # (S,)
    normals, offsets = _plane_grid(n, m0, c, angles0.reshape(-1), shifts0)
    out0, in0, votes0 = score_planes(view, normals, offsets, config, gate, chunk_planes, occluded)
    if config.init == "eigen+box" and config.box_axes == 2:
        # A round footprint has no faces: its rectangle's other axis is the plane that maps the
        # visible surface onto itself, which votes best and completes nothing. Not a candidate,
        # so not scored (the fallback and the K shapes read this grid).
        votes0 = votes0.reshape(-1, A * S)
        votes0 = votes0.at[2].set(jnp.where(box_like, votes0[2], jnp.inf)).reshape(-1)
    k = jnp.argmin(votes0)
    ks, rem = k // (A * S), k % (A * S)
    ia, js = rem // S, rem % S
    # Each initial axis keeps its best orientations (the best shift of each) and refines them on
    # their own: on the coarse grid the right plane can lose to a wrong one only because its
    # true shift lies between two steps, so one chain per axis is not enough.
    n_chains = min(config.n_chains, A)
    per_angle = votes0.reshape(-1, A, S)
    best_shift = jnp.argmin(per_angle, axis=2)  # (n_starts, A)
    best_vote = jnp.min(per_angle, axis=2)
    _, top = jax.lax.top_k(-best_vote, n_chains)  # (n_starts, n_chains)
    rows = jnp.arange(per_angle.shape[0])[:, None]
    chains = (
        angles0[rows, top].reshape(-1),
        shifts0[best_shift[rows, top]].reshape(-1),
        best_vote[rows, top].reshape(-1),
    )
    chain_start = jnp.repeat(jnp.arange(per_angle.shape[0]), n_chains)
    da = config.angle_range / max((A - 1) / 2, 1) * fans[chain_start][:, None]  # (C, 1)
    ds = (config.shift_max - config.shift_min) * L / max(S - 1, 1)

    def refine_level(chains, da, ds):
        best_a, best_s, best_vote = chains  # (C,) each
        angles = best_a[:, None] + unit_a[None, :] * da  # (C, A)
        shifts = best_s[:, None] + (2.0 * unit_s - 1.0)[None, :] * ds  # (C, S)
        normals, offsets = jax.vmap(_plane_grid, in_axes=(None, None, None, 0, 0))(
            n, m0, c, angles, shifts
        )
        # Every chain's planes in one flat set: a vmap over chains would batch the kernel's
        # matrix-vector sums, which XLA:CPU runs about twice as slowly per plane.
        _, _, votes = score_planes(
            view, normals.reshape(-1, 3), offsets.reshape(-1), config, gate, chunk_planes, occluded
        )
        votes = votes.reshape(-1, A * S)
        k = jnp.argmin(votes, axis=1)
        vote_k = jnp.take_along_axis(votes, k[:, None], axis=1)[:, 0]
        better = vote_k < best_vote
        rows = jnp.arange(votes.shape[0])
        new = (
            jnp.where(better, angles[rows, k // S], best_a),
            jnp.where(better, shifts[rows, k % S], best_s),
            jnp.minimum(vote_k, best_vote),
        )
        return new, (angles, shifts, votes.reshape(-1, A, S))

    r_angles, r_shifts, r_votes = [], [], []
    for _level in range(config.n_refine):
        chains, (ang, sh, vo) = refine_level(chains, da, ds)
        da = da / max((A - 1) / 2, 1)
        ds = 2.0 * ds / max(S - 1, 1)
        # Report the refinement grids of the chain that ends up best (selected below).
        r_angles.append(ang)
        r_shifts.append(sh)
        r_votes.append(vo)
    handicap = jnp.where(chain_start > 0, 1.0 + config.start_margin, 1.0)
    if config.init == "eigen+box" and config.box_favour > 0.0:
        favour = jnp.where(chain_start > 0, 1.0 - config.box_favour, 1.0)
        handicap = jnp.where(box_like, favour, handicap)
    score = chains[2] * handicap
    if config.init == "eigen+box" and config.box_axes == 2:
        other = chain_start == 2
        handicap = jnp.where(other, 1.0 - config.other_axis_favour, handicap)
        # A round footprint's other-axis chains were refined from its unscored planes.
        score = jnp.where(other & ~box_like, jnp.inf, chains[2] * handicap)
    win = jnp.argmin(score)
    best_a, best_s, best_vote = chains[0][win], chains[1][win], chains[2][win]
    r_angles = [a[win] for a in r_angles]
    r_shifts = [a[win] for a in r_shifts]
    r_votes = [a[win] for a in r_votes]

    normal = jnp.cos(best_a) * m0 + jnp.sin(best_a) * side
    offset = normal @ c + best_s
    mirrored, keep, plaus = mirror_view(view, normal, offset, config)
    R = config.n_refine
    return SymmetryResult(
        normal=normal,
        offset=offset,
        angle=best_a,
        shift=best_s,
        vote=best_vote,
        centroid=c,
        initial_axis=s,
        extent=L,
        angles=angles0,
        shifts=shifts0,
        votes=votes0.reshape(-1, A, S),
        vote_outside=out0.reshape(-1, A, S),
        vote_inside=in0.reshape(-1, A, S),
        best_index=jnp.stack([ks, ia, js]).astype(jnp.int32),
        best_start=chain_start[win].astype(jnp.int32),
        refine_angles=jnp.stack(r_angles) if R else jnp.full((1, A), jnp.nan),
        refine_shifts=jnp.stack(r_shifts) if R else jnp.full((1, S), jnp.nan),
        refine_votes=jnp.stack(r_votes) if R else jnp.full((1, A, S), jnp.nan),
        points=view.points,
        valid=view.valid,
        mirrored=mirrored,
        mirrored_keep=keep,
        plausibility=plaus,
    )
