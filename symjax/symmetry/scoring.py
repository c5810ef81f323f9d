"""The visibility vote of Eq. 3 for a set of planes of one view (paper Section II-A.4).

Kernels for one view and one hypothesis, batched with ``vmap`` by the callers.
"""

from __future__ import annotations

import functools

import jax
import jax.numpy as jnp

from symjax.geometry import reflect
from symjax.symmetry.config import SymmetryConfig
from symjax.symmetry.view import OCCLUDER_OFFSET, ViewArrays

__all__ = ["point_terms", "reflect", "score_planes"]

# ---------------------------------------------------------------------------------------------
# Kernels (one view / one hypothesis; batched with vmap outside)


#: ``jnp.dot`` at full float32 precision (a GPU would otherwise multiply in TF32).
_dot = functools.partial(jnp.dot, precision=jax.lax.Precision.HIGHEST)


def _camera_rows(view: ViewArrays, p):
    """World points as rows p (3, N) in the camera frame, rows (3, N).

    Three multiply-adds a row: XLA:CPU's matrix products with a dimension of 3, (N, 3) x (3, 3)
    or (3, 3) x (3, N), are several times slower.
    """
    d = p - view.t_wc[:, None]
    R = view.R_wc
    return jnp.stack([R[0, k] * d[0] + R[1, k] * d[1] + R[2, k] * d[2] for k in range(3)])


def _project(view: ViewArrays, q):
    """Pixel coordinates (N, 2) and depth (N,) of world points q (N, 3)."""
    x, y, z = _camera_rows(view, q.T)
    zs = jnp.where(z > 1e-6, z, 1e-6)
    K = view.K
    u = (K[0, 0] * x + K[0, 1] * y) / zs + K[0, 2]
    v = K[1, 1] * y / zs + K[1, 2]
    return u, v, z


def _unpacked(pix):
    """The image's values (:attr:`ViewArrays.image`) as ``(value, on_occluder)``: the depth of
    an occluder's pixel without its offset, and whether the pixel is an occluder's."""
    occluder = pix >= OCCLUDER_OFFSET
    return jnp.where(occluder, pix - OCCLUDER_OFFSET, pix), occluder


def point_terms(view: ViewArrays, q, config: SymmetryConfig):
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
    pix = _unpacked(view.image[rr.astype(jnp.int32), cc.astype(jnp.int32)])[0]
    dist_px = jnp.maximum(-pix, 0.0) + extra
    obs_depth = jnp.maximum(pix, 0.0)
    in_front_of_cam = z > 1e-6
    inside = (dist_px <= 0.0) & in_front_of_cam
    # A mirrored point behind the camera contradicts any hypothesis: the worst outside distance.
    far = jnp.float32(H * H + W * W)
    delta1 = jnp.where(inside, 0.0, jnp.where(in_front_of_cam, dist_px * dist_px, far))
    in_front = inside & (obs_depth > 0) & (z < obs_depth - config.depth_tolerance)
    delta2 = jnp.where(in_front, obs_depth - z, 0.0)
    return delta1, delta2, inside


def _mirror_pixels(view: ViewArrays, rows, normal, offset):
    """Pixel lookup of the points mirrored across one plane (the kernel's first stage).

    Args:
        view: The view.
        rows: ``(world, camera)``, each (3, N): the observed points' coordinates as rows, in
            the world and the camera frame (shared by all planes). As rows the plane distance
            is three multiply-adds fused into the projection; as an (N, 3) matrix product with
            the normals it was a pass of its own (a tenth of the kernel).
        normal: (3,) unit plane normal (world).
        offset: () plane offset, metres.

    Returns:
        ``(index, depth_or_extra)``, each (N,): flat index of the nearest in-image pixel, and
        the depth of the mirrored point along the optical axis (metres, > 0) where it projects
        into the image, minus the distance (pixels) from its rounded projection to the nearest
        in-image pixel where it projects outside, -inf behind the camera.
    """
    H, W = view.image.shape[0], view.image.shape[1]
    p, c = rows
    # Mirroring is affine, so in the camera frame q = R^T (p - t) - 2 (n . p - d) R^T n.
    dist = normal[0] * p[0] + normal[1] * p[1] + normal[2] * p[2] - offset
    a = normal @ view.R_wc
    x = c[0] - 2.0 * dist * a[0]
    y = c[1] - 2.0 * dist * a[1]
    z = c[2] - 2.0 * dist * a[2]
    front = z > 1e-6
    iz = 1.0 / jnp.where(front, z, 1e-6)
    K = view.K
    col = jnp.round((K[0, 0] * x + K[0, 1] * y) * iz + K[0, 2])
    row = jnp.round(K[1, 1] * y * iz + K[1, 2])
    cc = jnp.clip(col, 0, W - 1)
    rr = jnp.clip(row, 0, H - 1)
    # Outside the image the distance transform continues: add the distance to the border pixel.
    extra = jnp.sqrt((col - cc) ** 2 + (row - rr) ** 2)
    # One array for both: the depth matters only inside the image, the extra distance only
    # outside it (one pass less through memory for the kernel's second stage).
    depth_or_extra = jnp.where(front, jnp.where(extra > 0.0, -extra, z), -jnp.inf)
    return rr.astype(jnp.int32) * W + cc.astype(jnp.int32), depth_or_extra


def _rows(view: ViewArrays):
    """The points as rows (3, N), world and camera frame (see :func:`_mirror_pixels`)."""
    p = view.points.T
    return p, _camera_rows(view, p)


def _unprojectable(n_points: int, normals, dtype):
    """Stage-one output for hypotheses that cannot be scored (non-finite input): every mirrored
    point counts as behind the camera, so the hypothesis gets the worst vote, never NaN."""
    shape = (normals.shape[0], n_points)
    return jnp.zeros(shape, jnp.int32), jnp.full(shape, -jnp.inf, dtype)


def score_planes(
    view: ViewArrays,
    normals,
    offsets,
    config: SymmetryConfig,
    gate=None,
    chunk: int = 256,
    occluded=None,
):
    """Eq. 3 for many planes of one view.

    Mirrored points are looked up in the packed distance-transform/depth image; outside the mask
    the squared distance (pixels^2) counts (Huber's loss beyond ``config.outside_huber_px``),
    inside the mask the depth by which a point lies in front of the observed surface (metres);
    both are averaged over their subset of points (or over all points,
    ``config.normalize="all"``). Points that fall on an occluder's pixels behind its surface are
    hidden and belong to neither subset (a point in front of it counts inside, with its
    ``delta_2``).

    Args:
        view: One view.
        normals: (P, 3) unit plane normals.
        offsets: (P,) plane offsets, metres (planes ``{x : n . x = d}``).
        config: Weights, tolerance, normalisation.
        gate: Optional scalar bool, traced and not batched: False scores every plane as the worst.
            Defaults to "all inputs finite". Callers that ``vmap`` over views pass one gate for
            the whole batch so that the stage stays a conditional (see below).
        chunk: Planes scored at a time (no effect on the result).
        occluded: Optional scalar bool, traced and not batched: whether the view has occluders'
            pixels (only then are they told apart and the hidden points counted). Defaults to
            ``view.occluded``; callers that ``vmap`` over views pass the batch's ``any`` (False
            for a view with occluders would read their offset depths as depths).

    Returns:
        ``(outside, inside, votes)``, each (P,): ``E[delta_1]`` (pixels^2), ``E[delta_2]``
        (metres), and ``w_outside * outside + w_inside * inside``.
    """
    if gate is None:
        gate = jnp.isfinite(normals).all() & jnp.isfinite(offsets).all()
        gate = gate & jnp.isfinite(view.points).all()
    occluded = view.occluded if occluded is None else occluded
    P = normals.shape[0]
    rows = _rows(view)
    if chunk == 0 or P <= chunk:
        outside, inside = _score_chunk(view, rows, normals, offsets, config, gate, occluded)
    else:
        # Chunks keep the (hypotheses x points) intermediates in cache: 1,000 planes x 40,000
        # points would otherwise stream 160 MB per array through memory.
        # Chunks of equal size: 70 planes in chunks of 64 would score 128.
        size = -(-P // -(-P // chunk))
        pad = -P % size
        n = jnp.concatenate([normals, jnp.repeat(normals[-1:], pad, axis=0)])
        d = jnp.concatenate([offsets, jnp.repeat(offsets[-1:], pad, axis=0)])
        outside, inside = jax.lax.map(
            lambda nd: _score_chunk(view, rows, nd[0], nd[1], config, gate, occluded),
            (n.reshape(-1, size, 3), d.reshape(-1, size)),
        )
        outside, inside = outside.reshape(-1)[:P], inside.reshape(-1)[:P]
    return outside, inside, config.w_outside * outside + config.w_inside * inside


#: Steps of :func:`_score_chunk`'s loop over a cloud's points, at least (slabs of at least
#: :data:`MIN_SLAB` points). The loop stops after the last valid point, so a cloud padded to a
#: power of two costs at most an eighth more than its own points; more, smaller steps cost more
#: than they save (40,000 points x 35 planes: 13 ms in slabs of 8,192, 19 ms in slabs of 1,024).
SLABS = 8
MIN_SLAB = 1024
#: Plane-point pairs per step, at most: the step's arrays (pixel index, depth, terms) stay in
#: cache when more planes are scored at once (the default search's 140 refinement planes x
#: 40,000 points: 41 -> 34 ms in slabs of 2,048 instead of 8,192; 35 planes keep 8,192).
SLAB_ELEMENTS = 35 * 8192


def _slab_size(n_points: int, n_planes: int) -> int:
    """Points per step of :func:`_score_chunk`'s loop: at most :data:`SLAB_ELEMENTS` plane-point
    pairs (and :data:`SLABS` steps), at least :data:`MIN_SLAB` points, a divisor of the bucket."""
    per_planes = 1 << max(0, (SLAB_ELEMENTS // max(n_planes, 1)).bit_length() - 1)
    slab = max(MIN_SLAB, min(n_points // SLABS, per_planes))
    return slab if n_points % slab == 0 else n_points


def _score_chunk(view: ViewArrays, rows, normals, offsets, cfg: SymmetryConfig, gate, occluded):
    """:func:`score_planes` for one chunk of planes: ``(outside, inside)``, each (P,)."""
    N = view.points.shape[0]
    slab = _slab_size(N, normals.shape[0])
    index = jnp.arange(N)
    last = jnp.max(jnp.where(view.valid, index, -1))
    used = (last + slab) // slab  # slabs up to the last valid point (0 if none)
    zero = jnp.zeros(normals.shape[0], view.points.dtype)

    def loop(hidden: bool):
        def step(k, acc):
            part = tuple(jax.lax.dynamic_slice_in_dim(r, k * slab, slab, axis=1) for r in rows)
            valid = jax.lax.dynamic_slice_in_dim(view.valid, k * slab, slab)
            sums = _slab_sums(view, part, valid, normals, offsets, cfg, gate, hidden)
            return tuple(a + b for a, b in zip(acc, sums, strict=True))

        return jax.lax.fori_loop(0, used, step, (zero,) * (4 if hidden else 3))

    # Without occluders no point can hide behind one: the loop that does not look (telling
    # the occluders' pixels apart and counting the hidden points cost 12-16 % of the search).
    s_out, s_in, n_in, n_hidden = jax.lax.cond(
        occluded, lambda: loop(True), lambda: (*loop(False), zero)
    )
    n_valid = view.valid.sum().astype(zero.dtype)
    n_out = n_valid - n_in - n_hidden
    if cfg.normalize == "all":
        n_out = n_in = jnp.broadcast_to(n_valid, n_in.shape)
    return s_out / jnp.maximum(n_out, 1.0), s_in / jnp.maximum(n_in, 1.0)


def _outside_loss(dist, huber_px: float):
    """delta_1 of points ``dist`` pixels outside the mask: the square (Eq. 3), or Huber's loss
    with threshold ``huber_px`` > 0 (:attr:`SymmetryConfig.outside_huber_px`)."""
    if huber_px <= 0.0:
        return dist * dist
    return jnp.where(dist <= huber_px, dist * dist, huber_px * (2.0 * dist - huber_px))


def _slab_sums(
    view: ViewArrays, rows, valid, normals, offsets, cfg: SymmetryConfig, gate, hidden: bool
):
    """Sums over one slab of points (``rows`` as :func:`_mirror_pixels`, ``valid`` (S,)), per
    plane (P,): outside ``delta_1``, inside ``delta_2``, the number of valid points that project
    inside the mask and, with ``hidden``, the number hidden behind an occluder (then neither
    inside nor outside)."""
    H, W = view.image.shape[0], view.image.shape[1]

    def project(normals, offsets):
        return jax.vmap(_mirror_pixels, in_axes=(None, None, 0, 0))(view, rows, normals, offsets)

    # The conditional is a fusion boundary: without it XLA:CPU fuses the projection into the
    # gather and into every reduction below and recomputes it in each (measured 3-6x slower).
    index, zx = jax.lax.cond(
        gate,
        project,
        lambda n, o: _unprojectable(valid.shape[0], n, rows[0].dtype),
        normals,
        offsets,
    )
    pix = jnp.take(view.image.reshape(H * W), index, mode="clip")
    if hidden:
        pix, on_occluder = _unpacked(pix)
    extra = jnp.maximum(-zx, 0.0)
    front = zx > -jnp.inf
    dist = jnp.maximum(-pix, 0.0) + extra
    # The distance transform is 0 on the mask and >= 1 px off it: inside means dist == 0, where
    # delta_1 is 0; delta_2 is 0 outside.
    inside = (dist <= 0.0) & front
    # A mirrored point behind the camera contradicts any hypothesis: the worst outside distance.
    far = jnp.asarray(H * H + W * W, dist.dtype)
    delta1 = jnp.where(front, _outside_loss(dist, cfg.outside_huber_px), far)
    obs_depth = jnp.maximum(pix, 0.0)
    ahead = inside & (obs_depth > 0) & (zx < obs_depth - cfg.depth_tolerance)
    delta2 = jnp.where(ahead, obs_depth - zx, 0.0)
    valid = valid.astype(dist.dtype)
    # Sums over points as products with the validity vector: XLA:CPU runs a reduction with the
    # per-point terms fused into it as scalar code (measured 7x slower than a vectorised loop
    # that writes the terms, then a matrix-vector product over them).
    sums = (_dot(delta1, valid), _dot(delta2, valid))
    if not hidden:
        return (*sums, _dot(inside.astype(dist.dtype), valid))
    # Behind an occluder a mirrored point cannot be seen: no evidence for or against the plane.
    # Counted among the points inside the mask (with delta_2 = 0) it would dilute E[delta_2], and
    # a plane that mirrors the view behind its occluder would look the more plausible the more
    # it hides there (separated clutter objects: 216 -> 223 of 232 planes right; alone: 225).
    behind = inside & on_occluder & ~ahead
    seen = (inside & ~behind).astype(dist.dtype)
    return (*sums, _dot(seen, valid), _dot(behind.astype(dist.dtype), valid))


#: Points sampled for the extent and the bounding-box orientation.
