"""Symmetry-plane search scored by visibility (paper Section II-A, Eq. 1-4).

All hypotheses of a view are scored by one ``vmap`` of a per-hypothesis kernel; all views of a
batch by ``lax.map`` (chunks of ``vmap``) inside the same ``jit``.
"""

from __future__ import annotations

import functools
from collections.abc import Sequence
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

from symjax._pytree import pytree_dataclass
from symjax.errors import InvalidInputError, ShapeError
from symjax.observation import MIN_POINTS, Observation, point_bucket
from symjax.symmetry.config import SymmetryConfig

__all__ = [
    "SymmetryResult",
    "ViewArrays",
    "prepare_view",
    "search",
    "search_batch",
    "complete",
    "reflect",
    "score_planes",
]


@pytree_dataclass
class ViewArrays:
    """Device arrays of one view (or a batch, with a leading axis) as the kernel reads them.

    Attributes:
        points: (N, 3) world points, metres; padded rows are ignored.
        valid: (N,) bool.
        table_normal: (3,) unit up normal of the table.
        R_wc: (3, 3) camera-to-world rotation.
        t_wc: (3,) camera centre, metres.
        K: (3, 3) intrinsics, pixels.
        image: (H, W, 2) per pixel ``[distance to the mask (pixels, 0 inside), observed depth
            (metres, 0 = none)]``, packed so that one gather serves both terms.
    """

    points: Any
    valid: Any
    table_normal: Any
    R_wc: Any
    t_wc: Any
    K: Any
    image: Any


@pytree_dataclass
class SymmetryResult:
    """Outcome of the search for one view (or a batch, with a leading view axis).

    The plane is ``{x : normal . x = offset}``, perpendicular to the table, its normal pointing
    away from the camera. Orientations are angles about the table normal relative to the
    normal of the paper's initial plane (Eq. 1); shifts are metres along the rotated normal from
    the centroid. ``angles``/``shifts``/``votes`` hold the level-0 grid (one n x m fan per initial
    axis; start 0 is the paper's grid), ``refine_*`` the coarse-to-fine levels.

    Attributes:
        normal: (3,) unit plane normal.
        offset: () plane offset, metres.
        angle: () orientation of the best plane, radians.
        shift: () shift of the best plane from the centroid along its normal, metres.
        vote: () vote of the best plane (Eq. 3).
        centroid: (3,) centroid ``c`` of the visible points.
        initial_axis: (3,) initial symmetry axis ``s`` in the table plane (Eq. 1).
        extent: () object extent ``L`` used to scale the shifts, metres.
        angles: (n_starts, n_angles) level-0 orientations, radians.
        shifts: (n_shifts,) level-0 shifts, metres.
        votes: (n_starts, n_angles, n_shifts) level-0 votes ``w_out E[d1] + w_in E[d2]``.
        vote_outside: (n_starts, n_angles, n_shifts) ``E[delta_1]``, pixels^2.
        vote_inside: (n_starts, n_angles, n_shifts) ``E[delta_2]``, metres.
        best_index: (3,) int (start, angle, shift) of the best level-0 hypothesis.
        best_start: () int, the initial axis whose refined chain won (refinement runs per start).
        refine_angles: (n_refine, n_angles) radians, of the winning chain. With ``n_refine=0``
            the ``refine_*`` arrays hold one row of NaN (zero-size leaves do not batch).
        refine_shifts: (n_refine, n_shifts) metres.
        refine_votes: (n_refine, n_angles, n_shifts).
        points: (N, 3) observed points; valid: (N,) their validity.
        mirrored: (N, 3) points mirrored across the best plane.
        mirrored_keep: (N,) mirrored points kept in the completion (valid and not in front of an
            observed surface).
        plausibility: (N,) plausibility in [0, 1] of each mirrored point under the best plane.
    """

    normal: Any
    offset: Any
    angle: Any
    shift: Any
    vote: Any
    centroid: Any
    initial_axis: Any
    extent: Any
    angles: Any
    shifts: Any
    votes: Any
    vote_outside: Any
    vote_inside: Any
    best_index: Any
    best_start: Any
    refine_angles: Any
    refine_shifts: Any
    refine_votes: Any
    points: Any
    valid: Any
    mirrored: Any
    mirrored_keep: Any
    plausibility: Any

    @property
    def completed_points(self):
        """(2N, 3) observed then mirrored points (use :attr:`completed_valid`)."""
        return jnp.concatenate([self.points, self.mirrored], axis=-2)

    @property
    def completed_valid(self):
        """(2N,) validity of :attr:`completed_points`."""
        return jnp.concatenate([self.valid, self.mirrored_keep], axis=-1)

    @property
    def completed_plausibility(self):
        """(2N,) plausibility of :attr:`completed_points` (1 for observed points)."""
        return jnp.concatenate([jnp.ones_like(self.plausibility), self.plausibility], axis=-1)

    def completed_cloud(self) -> np.ndarray:
        """The completed cloud of one view as numpy (M, 3): observed plus kept mirrored points."""
        if np.ndim(self.points) != 2:
            raise ShapeError("completed_cloud() needs one view; index the batch first: result[i]")
        return np.asarray(self.completed_points)[np.asarray(self.completed_valid)]

    def mirrored_cloud(self) -> np.ndarray:
        """Kept mirrored points of one view as numpy (M, 3)."""
        return np.asarray(self.mirrored)[np.asarray(self.mirrored_keep)]

    def __len__(self) -> int:
        if np.ndim(self.points) != 3:
            raise TypeError("a single-view SymmetryResult has no len()")
        return int(np.shape(self.points)[0])

    def __getitem__(self, i) -> SymmetryResult:
        """The result of view ``i`` of a batched result."""
        return jax.tree_util.tree_map(lambda x: x[i], self)


# ---------------------------------------------------------------------------------------------
# Host-side preparation


def prepare_view(obs: Observation, n_points: int | None = None) -> ViewArrays:
    """Packs one observation for the kernel: distance transform and depth in one image.

    Args:
        obs: A single (unbatched) observation.
        n_points: Pad the points to this many rows (default: no padding).

    Raises:
        ShapeError: If ``obs`` is batched or its images disagree with its camera.
    """
    import cv2

    if not isinstance(obs, Observation):
        raise InvalidInputError(f"expected a symjax.Observation, got {type(obs).__name__}")
    if np.ndim(obs.points) != 2:
        raise ShapeError(
            f"expected one view (points (N, 3)), got points {np.shape(obs.points)}; "
            "use search_batch for several views"
        )
    mask = np.asarray(obs.mask, bool)
    depth = np.asarray(obs.depth, np.float32)
    if mask.shape != depth.shape:
        raise ShapeError(f"mask {mask.shape} and depth {depth.shape} images must match")
    if not mask.any():
        raise InvalidInputError("segmentation mask is empty")
    n_valid = int(np.asarray(obs.valid).sum())
    if n_valid < MIN_POINTS:
        raise InvalidInputError(f"observation has {n_valid} valid points; need >= {MIN_POINTS}")
    if n_points is not None:
        obs = obs.padded(n_points)
    # Distance (pixels) from every pixel to the nearest mask pixel; exact Euclidean.
    dt = cv2.distanceTransform((~mask).astype(np.uint8), cv2.DIST_L2, cv2.DIST_MASK_PRECISE)
    T = np.asarray(obs.camera.T_world_cam, np.float64)
    return ViewArrays(
        points=jnp.asarray(np.asarray(obs.points, np.float32)),
        valid=jnp.asarray(np.asarray(obs.valid, bool)),
        table_normal=jnp.asarray(np.asarray(obs.table.normal, np.float32)),
        R_wc=jnp.asarray(T[:3, :3].astype(np.float32)),
        t_wc=jnp.asarray(T[:3, 3].astype(np.float32)),
        K=jnp.asarray(np.asarray(obs.camera.K, np.float32)),
        image=jnp.asarray(np.stack([dt.astype(np.float32), depth], axis=-1)),
    )


# ---------------------------------------------------------------------------------------------
# Kernels (one view / one hypothesis; batched with vmap outside)


def reflect(points, normal, offset):
    """Mirrors points (..., 3) across the plane ``{x : normal . x = offset}`` (Eq. 2)."""
    dist = points @ normal - offset
    return points - 2.0 * dist[..., None] * normal[None, :]


def _project(view: ViewArrays, q):
    """Pixel coordinates (N, 2) and depth (N,) of world points q (N, 3)."""
    xc = (q - view.t_wc[None, :]) @ view.R_wc
    z = xc[:, 2]
    zs = jnp.where(z > 1e-6, z, 1e-6)
    K = view.K
    u = (K[0, 0] * xc[:, 0] + K[0, 1] * xc[:, 1]) / zs + K[0, 2]
    v = K[1, 1] * xc[:, 1] / zs + K[1, 2]
    return u, v, z


def _point_terms(view: ViewArrays, q, cfg: SymmetryConfig):
    """Per-point visibility terms of mirrored points q (N, 3).

    Returns:
        ``(delta1, delta2, inside)``: squared distance to the mask (pixels^2, 0 inside), depth by
        which a point lies in front of the observed surface (metres, 0 if not), and whether the
        point projects inside the mask.
    """
    H, W = view.image.shape[0], view.image.shape[1]
    u, v, z = _project(view, q)
    col = jnp.round(u)
    row = jnp.round(v)
    cc = jnp.clip(col, 0, W - 1)
    rr = jnp.clip(row, 0, H - 1)
    # Outside the image, the distance transform continues: add the distance to the border pixel.
    extra = jnp.hypot(col - cc, row - rr)
    pix = view.image[rr.astype(jnp.int32), cc.astype(jnp.int32)]
    dist_px = pix[:, 0] + extra
    obs_depth = pix[:, 1]
    in_front_of_cam = z > 1e-6
    inside = (dist_px <= 0.0) & in_front_of_cam
    # A mirrored point behind the camera contradicts any hypothesis: the worst outside distance.
    far = jnp.float32(H * H + W * W)
    delta1 = jnp.where(inside, 0.0, jnp.where(in_front_of_cam, dist_px * dist_px, far))
    in_front = inside & (obs_depth > 0) & (z < obs_depth - cfg.depth_tolerance)
    delta2 = jnp.where(in_front, obs_depth - z, 0.0)
    return delta1, delta2, inside


def _mirror_pixels(view: ViewArrays, cam_points, normal, offset):
    """Pixel lookup of the points mirrored across one plane (the kernel's first stage).

    Args:
        view: The view.
        cam_points: (N, 3) the observed points in the camera frame (shared by all planes).
        normal: (3,) unit plane normal (world).
        offset: () plane offset, metres.

    Returns:
        ``(index, extra, z)``, each (N,): flat index of the nearest in-image pixel, the distance
        (pixels) from the rounded projection to that pixel (0 inside the image; inf behind the
        camera), and the depth of the mirrored point along the optical axis, metres.
    """
    H, W = view.image.shape[0], view.image.shape[1]
    # Mirroring is affine, so in the camera frame q = R^T (p - t) - 2 (n . p - d) R^T n.
    dist = view.points @ normal - offset
    a = normal @ view.R_wc
    x = cam_points[:, 0] - 2.0 * dist * a[0]
    y = cam_points[:, 1] - 2.0 * dist * a[1]
    z = cam_points[:, 2] - 2.0 * dist * a[2]
    front = z > 1e-6
    iz = 1.0 / jnp.where(front, z, 1e-6)
    K = view.K
    col = jnp.round((K[0, 0] * x + K[0, 1] * y) * iz + K[0, 2])
    row = jnp.round(K[1, 1] * y * iz + K[1, 2])
    cc = jnp.clip(col, 0, W - 1)
    rr = jnp.clip(row, 0, H - 1)
    # Outside the image the distance transform continues: add the distance to the border pixel.
    extra = jnp.sqrt((col - cc) ** 2 + (row - rr) ** 2)
    extra = jnp.where(front, extra, jnp.inf)
    return rr.astype(jnp.int32) * W + cc.astype(jnp.int32), extra, z


def _unprojectable(view: ViewArrays, normals, offsets):
    """Stage-one output for hypotheses that cannot be scored (non-finite input): every mirrored
    point counts as behind the camera, so the hypothesis gets the worst vote, never NaN."""
    shape = (normals.shape[0], view.points.shape[0])
    dtype = view.points.dtype
    return (
        jnp.zeros(shape, jnp.int32),
        jnp.full(shape, jnp.inf, dtype),
        jnp.full(shape, -1.0, dtype),
    )


def score_planes(view: ViewArrays, normals, offsets, cfg: SymmetryConfig, gate=None):
    """Eq. 3 for many planes of one view.

    Mirrored points are looked up in the packed distance-transform/depth image; outside the mask
    the squared distance (pixels^2) counts, inside the mask the depth by which a point lies in
    front of the observed surface (metres); both are averaged over their subset of points (or
    over all points, ``cfg.normalize="all"``).

    Args:
        view: One view.
        normals: (P, 3) unit plane normals.
        offsets: (P,) plane offsets, metres (planes ``{x : n . x = d}``).
        cfg: Weights, tolerance, normalisation.
        gate: Optional scalar bool, traced and not batched: False scores every plane as the worst.
            Defaults to "all inputs finite". Callers that ``vmap`` over views pass one gate for
            the whole batch so that the stage stays a conditional (see below).

    Returns:
        ``(outside, inside, votes)``, each (P,): ``E[delta_1]`` (pixels^2), ``E[delta_2]``
        (metres), and ``w_outside * outside + w_inside * inside``.
    """
    if gate is None:
        gate = jnp.isfinite(normals).all() & jnp.isfinite(offsets).all()
        gate = gate & jnp.isfinite(view.points).all()
    P, chunk = normals.shape[0], cfg.chunk_hypotheses
    if chunk == 0 or P <= chunk:
        outside, inside = _score_chunk(view, normals, offsets, cfg, gate)
    else:
        # Chunks keep the (hypotheses x points) intermediates in cache: 1,000 planes x 40,000
        # points would otherwise stream 160 MB per array through memory.
        pad = -P % chunk
        n = jnp.concatenate([normals, jnp.repeat(normals[-1:], pad, axis=0)])
        d = jnp.concatenate([offsets, jnp.repeat(offsets[-1:], pad, axis=0)])
        outside, inside = jax.lax.map(
            lambda nd: _score_chunk(view, nd[0], nd[1], cfg, gate),
            (n.reshape(-1, chunk, 3), d.reshape(-1, chunk)),
        )
        outside, inside = outside.reshape(-1)[:P], inside.reshape(-1)[:P]
    return outside, inside, cfg.w_outside * outside + cfg.w_inside * inside


def _score_chunk(view: ViewArrays, normals, offsets, cfg: SymmetryConfig, gate):
    """:func:`score_planes` for one chunk of planes: ``(outside, inside)``, each (P,)."""
    H, W = view.image.shape[0], view.image.shape[1]
    cam_points = (view.points - view.t_wc[None, :]) @ view.R_wc

    def project(normals, offsets):
        return jax.vmap(_mirror_pixels, in_axes=(None, None, 0, 0))(
            view, cam_points, normals, offsets
        )

    # The conditional is a fusion boundary: without it XLA:CPU fuses the projection into the
    # gather and into every reduction below and recomputes it in each (measured 3-6x slower).
    index, extra, z = jax.lax.cond(
        gate, project, lambda n, o: _unprojectable(view, n, o), normals, offsets
    )
    pix = jnp.take(view.image.reshape(H * W, 2), index, axis=0, mode="clip")
    dist = pix[..., 0] + extra
    front = ~jnp.isinf(extra)
    inside = (dist <= 0.0) & front
    # A mirrored point behind the camera contradicts any hypothesis: the worst outside distance.
    far = jnp.asarray(H * H + W * W, dist.dtype)
    delta1 = jnp.where(front, dist * dist, far)
    obs_depth = pix[..., 1]
    ahead = inside & (obs_depth > 0) & (z < obs_depth - cfg.depth_tolerance)
    delta2 = jnp.where(ahead, obs_depth - z, 0.0)
    valid = view.valid[None, :]
    in_w = (valid & inside).astype(dist.dtype)
    out_w = (valid & ~inside).astype(dist.dtype)
    zero = jnp.zeros((), dist.dtype)
    # One variadic reduction: a single pass over the points instead of one per sum.
    s_out, s_in, n_in = jax.lax.reduce(
        (delta1 * out_w, delta2 * in_w, in_w),
        (zero, zero, zero),
        lambda a, b: tuple(x + y for x, y in zip(a, b, strict=True)),
        (1,),
    )
    n_valid = view.valid.sum().astype(dist.dtype)
    n_out = n_valid - n_in
    if cfg.normalize == "all":
        n_out = n_in = jnp.broadcast_to(n_valid, n_in.shape)
    return s_out / jnp.maximum(n_out, 1.0), s_in / jnp.maximum(n_in, 1.0)


#: Points sampled for the extent and the bounding-box orientation.
SAMPLE_POINTS = 4096


def _initial_plane(view: ViewArrays):
    """Centroid, initial axis s (Eq. 1), base plane normal m0 (away from camera), extent L."""
    n = view.table_normal
    w = view.valid.astype(jnp.float32)
    cnt = jnp.maximum(w.sum(), 1.0)
    c = (view.points * w[:, None]).sum(0) / cnt
    d = view.points - c[None, :]
    d = d - (d @ n)[:, None] * n[None, :]  # projection onto the table plane
    cov = (d * w[:, None]).T @ d / cnt
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

    sample = d[_valid_sample(view.valid)]

    def robust_extent(axis):
        lo, hi = jnp.percentile(sample @ axis, jnp.array([2.0, 98.0]))
        return hi - lo

    L = jnp.maximum(robust_extent(e_a), robust_extent(e_b))
    return c, s, m0, L


def _valid_sample(valid, size: int = SAMPLE_POINTS):
    """Indices (size,) of valid points spread evenly over them (repeats when fewer).

    The extent and the box orientation only need the shape of the cloud: a fixed-size sample
    keeps their sorts and sweeps cheap for 40,000-point views.
    """
    size = min(size, valid.shape[0])
    rank = jnp.cumsum(valid.astype(jnp.int32))
    n = jnp.maximum(rank[-1], 1)
    want = (jnp.arange(size) * n) // size + 1
    return jnp.clip(jnp.searchsorted(rank, want), 0, valid.shape[0] - 1)


def _box_angle(view: ViewArrays, c, m0, side, n_sweep: int = 90):
    """Orientation (radians, relative to m0) of the minimum-area rectangle bounding the
    table-projected cloud, by a sweep over [0, 90) deg (an edge direction is its normal)."""
    d = view.points[_valid_sample(view.valid)] - c[None, :]
    x, y = d @ m0, d @ side
    th = jnp.arange(n_sweep) * (jnp.pi / 2 / n_sweep)

    def area(t):
        a = jnp.cos(t) * x + jnp.sin(t) * y
        b = -jnp.sin(t) * x + jnp.cos(t) * y
        return (a.max() - a.min()) * (b.max() - b.min())

    return th[jnp.argmin(jax.vmap(area)(th))]


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


def _search_view(view: ViewArrays, cfg: SymmetryConfig, gate) -> SymmetryResult:
    """The whole search for one view (traced; jit and vmap are applied by the callers).

    ``gate`` is the unbatched scalar of :func:`score_planes`.
    """
    n = view.table_normal
    c, s, m0, L = _initial_plane(view)
    side = jnp.cross(n, m0)
    A, S = cfg.n_angles, cfg.n_shifts
    unit_a = jnp.linspace(-1.0, 1.0, A) if A > 1 else jnp.zeros(1)
    unit_s = jnp.linspace(0.0, 1.0, S) if S > 1 else jnp.full(1, 0.5)

    starts = [jnp.float32(0.0)]
    if cfg.init == "eigen+box":
        # Of the rectangle's two axes keep, as Eq. 1 does among the eigenvectors, the plane whose
        # normal is closest to the viewing direction: the other one maps the visible surface
        # onto itself, scores well and completes nothing behind the object.
        away = c - view.t_wc
        view_angle = jnp.arctan2(away @ side, away @ m0)
        a0, a1 = _wrap(box := _box_angle(view, c, m0, side)), _wrap(box + jnp.pi / 2)
        d0, d1 = jnp.abs(_wrap(a0 - view_angle)), jnp.abs(_wrap(a1 - view_angle))
        starts.append(jnp.where(d0 <= d1, a0, a1))
    starts = jnp.stack(starts)

    # Level 0: the paper's fan of n x m hypotheses around every initial axis, one vmap.
    angles0 = starts[:, None] + (unit_a * cfg.angle_range)[None, :]  # (n_starts, A)
    shifts0 = (cfg.shift_min + unit_s * (cfg.shift_max - cfg.shift_min)) * L  # (S,)
    normals, offsets = _plane_grid(n, m0, c, angles0.reshape(-1), shifts0)
    out0, in0, votes0 = score_planes(view, normals, offsets, cfg, gate)
    k = jnp.argmin(votes0)
    ks, rem = k // (A * S), k % (A * S)
    ia, js = rem // S, rem % S
    # Each initial axis keeps its best orientations (the best shift of each) and refines them on
    # their own: on the coarse grid the right plane can lose to a wrong one only because its
    # true shift lies between two steps, so one chain per axis is not enough.
    n_chains = min(cfg.n_chains, A)
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
    da = cfg.angle_range / max((A - 1) / 2, 1)
    ds = (cfg.shift_max - cfg.shift_min) * L / max(S - 1, 1)

    def refine_level(chain, steps):
        best_a, best_s, best_vote = chain
        da, ds = steps
        angles = best_a + unit_a * da
        shifts = best_s + (2.0 * unit_s - 1.0) * ds
        normals, offsets = _plane_grid(n, m0, c, angles, shifts)
        _, _, votes = score_planes(view, normals, offsets, cfg, gate)
        k = jnp.argmin(votes)
        better = votes[k] < best_vote
        new = (
            jnp.where(better, angles[k // S], best_a),
            jnp.where(better, shifts[k % S], best_s),
            jnp.minimum(votes[k], best_vote),
        )
        return new, (angles, shifts, votes.reshape(A, S))

    r_angles, r_shifts, r_votes = [], [], []
    for _level in range(cfg.n_refine):
        chains, (ang, sh, vo) = jax.vmap(refine_level, in_axes=(0, None))(chains, (da, ds))
        da = da / max((A - 1) / 2, 1)
        ds = 2.0 * ds / max(S - 1, 1)
        # Report the refinement grids of the chain that ends up best (selected below).
        r_angles.append(ang)
        r_shifts.append(sh)
        r_votes.append(vo)
    handicap = jnp.where(chain_start > 0, 1.0 + cfg.start_margin, 1.0)
    win = jnp.argmin(chains[2] * handicap)
    best_a, best_s, best_vote = chains[0][win], chains[1][win], chains[2][win]
    r_angles = [a[win] for a in r_angles]
    r_shifts = [a[win] for a in r_shifts]
    r_votes = [a[win] for a in r_votes]

    normal = jnp.cos(best_a) * m0 + jnp.sin(best_a) * side
    offset = normal @ c + best_s
    mirrored = reflect(view.points, normal, offset)
    delta1, delta2, _ = _point_terms(view, mirrored, cfg)
    keep = view.valid & (delta2 <= 0.0)
    plaus = jnp.exp(-delta1 / cfg.plausibility_px**2) * jnp.exp(-delta2 / cfg.plausibility_depth)
    R = cfg.n_refine
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
        plausibility=jnp.where(view.valid, plaus, 0.0),
    )


@functools.partial(jax.jit, static_argnums=1)
def _search_jit(view: ViewArrays, cfg: SymmetryConfig) -> SymmetryResult:
    return _search_view(view, cfg, jnp.isfinite(view.points).all())


@functools.partial(jax.jit, static_argnums=(1, 2))
def _search_batch_jit(views: ViewArrays, cfg: SymmetryConfig, chunk: int) -> SymmetryResult:
    # lax.map with batch_size vmaps chunks of views: every hypothesis of a chunk in one vmap,
    # while memory stays bounded for 128 views x 40k points.
    gate = jnp.isfinite(views.points).all()
    return jax.lax.map(lambda v: _search_view(v, cfg, gate), views, batch_size=chunk)


# ---------------------------------------------------------------------------------------------
# Public entry points


def _check_cfg(cfg) -> SymmetryConfig:
    if cfg is None:
        return SymmetryConfig()
    if not isinstance(cfg, SymmetryConfig):
        raise InvalidInputError(f"cfg must be a SymmetryConfig, got {type(cfg).__name__}")
    return cfg


def search(obs: Observation, cfg: SymmetryConfig | None = None) -> SymmetryResult:
    """Finds the reflection symmetry plane perpendicular to the table of one view.

    Args:
        obs: One observation (points padded to any size; images of the camera's size).
        cfg: Search parameters; the paper's defaults when omitted.

    Returns:
        A :class:`SymmetryResult` (arrays without a batch axis).

    Raises:
        InvalidInputError: Bad observation (see :meth:`symjax.Observation.create`).
    """
    cfg = _check_cfg(cfg)
    if not isinstance(obs, Observation):
        raise InvalidInputError(f"search expects a symjax.Observation, got {type(obs).__name__}")
    view = prepare_view(obs, point_bucket(len(np.asarray(obs.points))))
    return _search_jit(view, cfg)


def search_batch(
    observations: Sequence[Observation], cfg: SymmetryConfig | None = None
) -> SymmetryResult:
    """Searches all hypotheses of all views in one jitted call.

    Views are padded to a common number of points (:func:`symjax.observation.point_bucket`) and
    image size, then scored by ``lax.map`` over chunks of ``cfg.chunk_views`` views, each chunk
    one ``vmap``.

    Args:
        observations: Single-view observations.
        cfg: Search parameters.

    Returns:
        A batched :class:`SymmetryResult` (leading axis = view; ``result[i]`` is view i).
    """
    cfg = _check_cfg(cfg)
    if isinstance(observations, Observation):
        raise InvalidInputError("search_batch takes a sequence of Observations; use search()")
    observations = list(observations)
    if not observations:
        raise InvalidInputError("search_batch got no observations")
    for i, o in enumerate(observations):
        if not isinstance(o, Observation):
            raise InvalidInputError(
                f"search_batch item {i} is a {type(o).__name__}, expected a symjax.Observation"
            )
    n = point_bucket(max(len(np.asarray(o.points)) for o in observations))
    views = [prepare_view(o, n) for o in observations]
    H = max(v.image.shape[0] for v in views)
    W = max(v.image.shape[1] for v in views)
    padded = []
    for v in views:
        h, w = v.image.shape[:2]
        if (h, w) != (H, W):
            img = np.asarray(v.image)
            # Pixels beyond a smaller image are outside its mask: extend the distance transform.
            import cv2

            mask = img[..., 0] <= 0
            big = np.zeros((H, W), bool)
            big[:h, :w] = mask
            dt = cv2.distanceTransform((~big).astype(np.uint8), cv2.DIST_L2, cv2.DIST_MASK_PRECISE)
            depth = np.zeros((H, W), np.float32)
            depth[:h, :w] = img[..., 1]
            v = ViewArrays(**{**v.__dict__, "image": jnp.asarray(np.stack([dt, depth], -1))})
        padded.append(v)
    stacked = jax.tree_util.tree_map(lambda *xs: jnp.stack(xs), *padded)
    chunk = cfg.chunk_views if cfg.chunk_views > 0 else len(padded)
    return _search_batch_jit(stacked, cfg, min(chunk, len(padded)))


def complete(obs: Observation | Sequence[Observation], cfg: SymmetryConfig | None = None):
    """Convenience entry point: completed cloud(s) by symmetry.

    Args:
        obs: One observation or a sequence of them.
        cfg: Search parameters.

    Returns:
        For one observation, ``(points (M, 3), result)``; for a sequence, a list of completed
        clouds and the batched result.
    """
    if isinstance(obs, Observation):
        res = search(obs, cfg)
        return res.completed_cloud(), res
    res = search_batch(obs, cfg)
    return [res[i].completed_cloud() for i in range(len(res))], res
