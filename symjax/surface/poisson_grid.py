"""The Poisson indicator function of oriented points on a regular grid, batched in JAX.

Kazhdan, Bolitho and Hoppe (2006) find the indicator function ``chi`` of the object whose gradient
best matches the field ``V`` of oriented normals: ``Lap(chi) = div(V)``. symjax solves it on a
regular grid of ``2**depth`` cells per axis (the finest level of the paper's octree of that depth)
spanning the cubic bounding box of the points enlarged by ``padding``:

1. each sample's area is estimated as the inverse of the smoothed sample density, so that dense
   and sparse parts of a view contribute by surface area, not by point count;
2. area x weight x normal is splatted trilinearly into ``V``, stored on a staggered grid (each
   component on the cell faces across its axis) so that its divergence lands on the nodes;
3. the 7-point discrete Poisson equation is solved exactly by one FFT pair: the indicator of an
   object inside the padded box is constant near the box faces, so the periodic solution is the
   free-space one up to a constant; Kazhdan's smoothing of ``V`` (a Gaussian here) is a product
   in the same spectral step;
4. the iso-value is the weighted mean of ``chi`` at the samples (Kazhdan's choice).

Steps 1-4 are one JAX kernel per view, vmapped over a padded batch.
"""

from __future__ import annotations

import functools
from collections.abc import Sequence
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

from symjax._kernel_store import StoredKernel
from symjax._pytree import pytree_dataclass
from symjax.errors import (
    DegenerateGeometryError,
    InvalidInputError,
    ShapeError,
)
from symjax.surface.config import PoissonConfig
from symjax.surface.normals import _as_points, check_not_degenerate

__all__ = ["PoissonGrid", "pack_views", "solve_grid", "solve_grids"]


@pytree_dataclass
class PoissonGrid:
    """The solved indicator function of one view (or a batch, with a leading view axis).

    Attributes:
        chi: (R, R, R) indicator function at the grid nodes, ``R = 2**depth``; larger inside.
        iso: () iso-value of the surface.
        origin: (3,) world position of node (0, 0, 0), metres.
        cell: () grid spacing, metres.
    """

    chi: Any
    iso: Any
    origin: Any
    cell: Any

    def __getitem__(self, i) -> PoissonGrid:
        """The grid of view ``i`` of a batch."""
        return jax.tree_util.tree_map(lambda x: x[i], self)


# ---------------------------------------------------------------------------------------------
# JAX kernel (one view)

_CORNERS = np.array([[i, j, k] for i in (0, 1) for j in (0, 1) for k in (0, 1)], dtype=np.int32)


def _trilinear(g, res: int):
    """Corner indices (N, 8, 3) and weights (N, 8) of continuous grid coordinates g (N, 3)."""
    base = jnp.floor(g)
    f = g - base
    idx = (base.astype(jnp.int32)[:, None, :] + _CORNERS[None, :, :]) % res
    c = jnp.asarray(_CORNERS, dtype=g.dtype)
    w = jnp.prod(jnp.where(c[None] > 0, f[:, None, :], 1.0 - f[:, None, :]), axis=-1)
    return idx, w


def _splat(g, values, res: int):
    """Scatter-adds values (N,) at grid coordinates g (N, 3) trilinearly into a (R, R, R) grid."""
    idx, w = _trilinear(g, res)
    flat = (idx[..., 0] * res + idx[..., 1]) * res + idx[..., 2]
    grid = (
        jnp.zeros((res**3,), values.dtype)
        .at[flat.reshape(-1)]
        .add((w * values[:, None]).reshape(-1))
    )
    return grid.reshape(res, res, res)


def _gather(idx, w, grid):
    """Trilinear interpolation (N,) of a (R, R, R) grid."""
    return jnp.sum(w * grid[idx[..., 0], idx[..., 1], idx[..., 2]], axis=-1)


def _frequencies(res: int):
    """Angular frequencies per cell k h (radians) of the rfftn layout, broadcastable to
    (R, R, R//2+1)."""
    k = 2 * np.pi * np.fft.fftfreq(res)
    kr = 2 * np.pi * np.fft.rfftfreq(res)
    return k[:, None, None], k[None, :, None], kr[None, None, :]


def _smoothed(x, sigma_cells: float):
    """Spectrum of x (R, R, R) times a Gaussian of standard deviation ``sigma_cells``."""
    kx, ky, kz = _frequencies(x.shape[0])
    gauss = np.exp(-0.5 * sigma_cells**2 * (kx**2 + ky**2 + kz**2)).astype(np.float32)
    return jnp.fft.rfftn(x) * gauss


def _poisson_view(points, normals, weights, valid, cfg: PoissonConfig) -> PoissonGrid:
    """Indicator function of one view. points/normals (N, 3), weights/valid (N,)."""
    res = cfg.resolution
    dtype = points.dtype
    big = jnp.asarray(jnp.finfo(dtype).max, dtype)
    lo = jnp.min(jnp.where(valid[:, None], points, big), axis=0)
    hi = jnp.max(jnp.where(valid[:, None], points, -big), axis=0)
    side = jnp.max(hi - lo) * cfg.padding
    cell = side / res
    # Node i sits at origin + i * cell; the points are centred in the box.
    origin = 0.5 * (lo + hi) - 0.5 * (res - 1) * cell
    g = (points - origin[None, :]) / cell
    g = jnp.where(valid[:, None], g, 0.5 * res)
    vmask = valid.astype(dtype)

    # Sample density (samples per cell, smoothed) on a grid half as fine, which is plenty for a
    # kernel of 1.5 cells and 8x cheaper: its inverse is each sample's share of the surface area.
    res_d = max(res // 2, 4)
    scale_d = res_d / res
    g_d = g * scale_d
    dens = jnp.fft.irfftn(
        _smoothed(_splat(g_d, vmask, res_d), cfg.density_smoothing * scale_d),
        s=(res_d, res_d, res_d),
    )
    idx_d, w_d = _trilinear(g_d, res_d)
    area = vmask / jnp.maximum(_gather(idx_d, w_d, dens), 1e-3)
    ws = weights * vmask if cfg.use_weights else vmask
    ws = jnp.maximum(ws, 0.0)

    # Staggered (MAC) layout: component c lives on the faces i + 1/2 along axis c, so that the
    # backward-difference divergence sits on the nodes and the 7-point Laplacian is its exact
    # partner (no half-cell shift, no checkerboard mode).
    div = jnp.zeros((res, res, res), dtype)
    for c in range(3):
        face = _splat(g - 0.5 * jnp.eye(3, dtype=dtype)[c][None, :], area * ws * normals[:, c], res)
        div = div + face - jnp.roll(face, 1, axis=c)
    kx, ky, kz = _frequencies(res)
    lap = (4 * (np.sin(kx / 2) ** 2 + np.sin(ky / 2) ** 2 + np.sin(kz / 2) ** 2)).astype(np.float32)
    lap[0, 0, 0] = 1.0
    # Lap chi = -div(n) with outward normals: chi is the inside indicator (larger inside).
    chi_hat = _smoothed(div, cfg.smoothing) / lap
    chi_hat = chi_hat.at[0, 0, 0].set(0.0)
    chi = jnp.fft.irfftn(chi_hat, s=(res, res, res))

    idx, w = _trilinear(g, res)
    c_at = _gather(idx, w, chi)
    wsum = jnp.sum(ws)
    iso = jnp.sum(ws * c_at) / jnp.where(wsum > 0, wsum, 1.0)
    return PoissonGrid(chi=chi.astype(dtype), iso=iso, origin=origin, cell=cell)


# Stored as exported StableHLO: a new process's first mesh skips the tracing
# (symjax._kernel_store).
_poisson_jit = StoredKernel(_poisson_view, (4,), "_poisson_jit")


@functools.partial(jax.jit, static_argnums=(4, 5))
def _poisson_batch_jit(points, normals, weights, valid, cfg: PoissonConfig, chunk: int):
    # lax.map over chunks of vmapped views: one call for the batch, memory bounded by the chunk.
    def one_chunk(args):
        return jax.vmap(_poisson_view, in_axes=(0, 0, 0, 0, None))(*args, cfg)

    b = points.shape[0]
    n_chunks = b // chunk
    args = (points, normals, weights, valid)
    chunked = jax.tree_util.tree_map(lambda x: x.reshape((n_chunks, chunk) + x.shape[1:]), args)
    out = jax.lax.map(one_chunk, chunked)
    return jax.tree_util.tree_map(lambda x: x.reshape((b,) + x.shape[2:]), out)


# ---------------------------------------------------------------------------------------------
# Host side: validation, packing, marching cubes


def _check_view(points, normals, weights, cfg: PoissonConfig, i: int | None = None):
    what = "points" if i is None else f"points of view {i}"
    p = _as_points(points, what)
    n = np.asarray(normals, dtype=np.float64)
    if n.shape != p.shape:
        raise ShapeError(f"normals must have the shape of the points {p.shape}, got {n.shape}")
    if not np.all(np.isfinite(n)):
        raise DegenerateGeometryError("normals contain NaN or inf; expected finite unit normals")
    norm = np.linalg.norm(n, axis=1)
    if np.any(norm < 1e-6):
        raise DegenerateGeometryError(
            f"{int(np.sum(norm < 1e-6))} normals have zero length; expected unit normals"
        )
    n = n / norm[:, None]
    if weights is None:
        w = np.ones(p.shape[0])
    else:
        w = np.asarray(weights, dtype=np.float64)
        if w.shape != (p.shape[0],):
            raise ShapeError(f"weights must have shape ({p.shape[0]},), got {w.shape}")
        if not np.all(np.isfinite(w)) or np.any(w < 0):
            raise InvalidInputError("weights must be finite and >= 0")
        if cfg.use_weights and np.sum(w > 0) < cfg.min_points:
            raise DegenerateGeometryError(
                f"only {int(np.sum(w > 0))} points have a positive weight; need {cfg.min_points}"
            )
    check_not_degenerate(p, cfg.min_points)
    # A few stray points would stretch the grid over empty space and swell the mesh into a blob.
    lo, hi = np.percentile(p, [1.0, 99.0], axis=0)
    robust, full = float(np.max(hi - lo)), float(np.max(np.ptp(p, axis=0)))
    if full > 3.0 * robust + 0.02:
        far = int(np.sum(np.any((p < lo - robust) | (p > hi + robust), axis=1)))
        raise DegenerateGeometryError(
            f"{what}: {far} points lie far from the rest (the cloud spans {full:.3g} m, 98% of it"
            f" {robust:.3g} m); expected one object: drop them first"
            " (symjax.surface.outlier_mask)"
        )
    return p, n, w


def pack_views(views: Sequence[tuple], config: PoissonConfig, n_points: int | None = None):
    """Validates views and pads them to one point count.

    Args:
        views: Sequence of ``(points (N_i, 3), normals (N_i, 3), weights (N_i,) or None)``.
        n_points: Padded point count (default: the largest N_i).
        config: Configuration (for ``min_points``).

    Returns:
        ``(points, normals, weights, valid)`` float32 arrays (B, N, 3), (B, N, 3), (B, N), bool
        (B, N).
    """
    checked = [_check_view(*v, config, i=i) for i, v in enumerate(views)]
    if not checked:
        raise InvalidInputError("views is empty; expected at least one (points, normals, weights)")
    n_max = max(c[0].shape[0] for c in checked)
    n = n_max if n_points is None else int(n_points)
    if n < n_max:
        raise ShapeError(f"n_points={n} is smaller than the largest view ({n_max} points)")
    b = len(checked)
    P = np.zeros((b, n, 3), np.float32)
    Nn = np.zeros((b, n, 3), np.float32)
    Wt = np.zeros((b, n), np.float32)
    V = np.zeros((b, n), bool)
    for i, (p, nn, w) in enumerate(checked):
        m = p.shape[0]
        P[i, :m], Nn[i, :m], Wt[i, :m], V[i, :m] = p, nn, w, True
    return P, Nn, Wt, V


def solve_grid(points, normals, weights, valid, config: PoissonConfig) -> PoissonGrid:
    """Solves the indicator function of one packed view (jitted; arrays from :func:`pack_views`).

    Args:
        points: (N, 3) float32 points, metres; padded rows have ``valid`` False.
        normals: (N, 3) unit outward normals.
        weights: (N,) non-negative weights.
        valid: (N,) bool.
        config: Configuration.
    """
    return _poisson_jit(points, normals, weights, valid, config)


def solve_grids(
    points, normals, weights, valid, config: PoissonConfig, chunk: int = 8
) -> PoissonGrid:
    """Solves the indicator functions of a padded batch of views in one jitted call.

    Args:
        points: (B, N, 3) float32 points, metres (see :func:`pack_views`).
        normals: (B, N, 3) unit outward normals.
        weights: (B, N) non-negative weights.
        valid: (B, N) bool, which rows are real points.
        config: Configuration.
        chunk: Views solved at once (0 = all; :class:`symjax.execution.ExecutionConfig`).

    Returns:
        A batched :class:`PoissonGrid` with chi (B, R, R, R).
    """
    if len(np.shape(points)) != 3 or np.shape(points)[-1] != 3:
        raise ShapeError(f"points must have shape (B, N, 3), got {np.shape(points)}")
    b, n = np.shape(points)[:2]
    expected = {"normals": (b, n, 3), "weights": (b, n), "valid": (b, n)}
    for name, arr in (("normals", normals), ("weights", weights), ("valid", valid)):
        if tuple(np.shape(arr)) != expected[name]:
            raise ShapeError(f"{name} must have shape {expected[name]}, got {np.shape(arr)}")
    # One fixed vmap width (never 1): XLA's rounding can change with the width, so a view's
    # grid is the same whatever its batch only if every batch runs at the same width.
    chunk = max(2, b if chunk == 0 else chunk)
    pad = (-b) % chunk
    arrs = [points, normals, weights, valid]
    # Host arrays stay on the host until the jitted call: an eager jnp op would compile a small
    # program for every new shape.
    xp = np if all(isinstance(a, np.ndarray) for a in arrs) else jnp
    arrs[3] = xp.asarray(arrs[3], bool)
    if pad:
        # Repeat the first view to fill the last chunk; the copies are dropped below.
        arrs = [xp.concatenate([a, xp.repeat(a[:1], pad, axis=0)], axis=0) for a in arrs]
    out = _poisson_batch_jit(*arrs, config, chunk)
    return jax.tree_util.tree_map(lambda x: x[:b], out) if pad else out
