"""Poisson surface reconstruction of oriented points (paper Section II-B): the entry points.

One call for a view, one for a batch; both pad the points to a size bucket
(:func:`symjax.geometry.bucket`) so that the jitted solver compiles once per bucket, not once
per cloud. The solver is :mod:`symjax.surface.poisson_grid`, the mesh extraction
:mod:`symjax.surface.isosurface`.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any, Literal

import jax
import numpy as np

from symjax._threads import map_in_threads
from symjax.array_types import ArrayLike
from symjax.errors import InvalidInputError, SymjaxError, config_or_default
from symjax.execution import ExecutionConfig
from symjax.geometry import cloud_bucket
from symjax.surface.config import PoissonConfig
from symjax.surface.isosurface import InsideOutError, evidence_hull, grid_to_mesh
from symjax.surface.normals import OrientedPoints
from symjax.surface.poisson_grid import pack_views, solve_grid, solve_grids

__all__ = ["poisson_reconstruct", "poisson_reconstruct_batch"]


def poisson_reconstruct(
    points: ArrayLike,
    normals: ArrayLike,
    weights: ArrayLike = None,
    config: PoissonConfig | None = None,
    table: Any = None,
):
    """Watertight mesh of one oriented point cloud.

    Args:
        points: (N, 3) points, metres, N >= ``config.min_points``.
        normals: (N, 3) outward normals (normalised here).
        weights: Optional (N,) non-negative per-point weights (e.g. the plausibility).
        config: :class:`PoissonConfig` (``depth`` 5 or 7 as in the paper).
        table: The :class:`~symjax.table.TablePlane` the object stands on: the surface is cut
            there and closed by it (nothing reaches under the table). None: no cut.

    Returns:
        A watertight ``trimesh.Trimesh`` in world coordinates, metres.

    Raises:
        ShapeError: On wrongly shaped inputs.
        EmptyInputError: With fewer than ``config.min_points`` points.
        DegenerateGeometryError: On collinear or coplanar points, NaN or zero normals, or when
            no closed surface can be extracted.
    """
    cfg = config_or_default(config, PoissonConfig)
    n = len(points) if hasattr(points, "__len__") else 0
    P, N, W, V = pack_views([(points, normals, weights)], cfg, cloud_bucket(max(n, 1)))
    table = _check_table(table)
    grid = jax.device_get(solve_grid(P[0], N[0], W[0], V[0], cfg))
    return _mesh(grid, (P, N, W, V), cfg, table)


def _mesh(grid, packed: tuple, cfg: PoissonConfig, table):
    """The grid's mesh; an inside-out indicator is solved again as a thin shell from the view's
    packed arrays (:func:`pack_views`, batch of one)."""
    P, N, W, V = packed
    hull = evidence_hull(P[0][V[0]], table) if cfg.clip_to_hull else None
    try:
        return grid_to_mesh(grid, cfg, table, hull)
    except InsideOutError:
        if cfg.thin_shell <= 0:
            raise
        return _thin_shell(P[0][V[0]], N[0][V[0]], W[0][V[0]], cfg, table)


def _thin_shell(points, normals, weights, cfg: PoissonConfig, table):
    """The mesh of an open sheet solved as a wall: each point gets a twin ``t`` behind it with
    the normal reversed (``t`` = ``cfg.thin_shell`` cells, at least 3 mm)."""
    p, n = np.asarray(points, np.float64), np.asarray(normals, np.float64)
    n = n / np.linalg.norm(n, axis=1, keepdims=True)
    w = np.asarray(weights, np.float64)
    cell = float(np.ptp(p, axis=0).max()) * cfg.padding / cfg.resolution
    t = max(cfg.thin_shell * cell, 0.003)
    P, N, W, V = pack_views([(np.concatenate([p, p - t * n]), np.concatenate([n, -n]),
                              np.concatenate([w, w]))], cfg, cloud_bucket(2 * len(p)))  # fmt: skip
    hull = evidence_hull(P[0][V[0]], table) if cfg.clip_to_hull else None
    mesh = grid_to_mesh(jax.device_get(solve_grid(P[0], N[0], W[0], V[0], cfg)), cfg, table, hull)
    mesh.metadata["thin_shell_m"] = t
    return mesh


def _check_table(table: Any):
    from symjax.table import TablePlane

    if table is not None and not isinstance(table, TablePlane):
        raise InvalidInputError(f"table must be a TablePlane or None, got {type(table).__name__}")
    return table


def _as_triple(view: Any) -> tuple:
    if isinstance(view, OrientedPoints):
        return view.points, view.normals, view.weights
    if isinstance(view, tuple) and len(view) in (2, 3):
        return view if len(view) == 3 else (*view, None)
    raise InvalidInputError(
        f"a Poisson view must be OrientedPoints or (points, normals[, weights]), got"
        f" {type(view).__name__}"
    )


def poisson_reconstruct_batch(
    views: Sequence[Any],
    config: PoissonConfig | None = None,
    execution: ExecutionConfig | None = None,
    errors: Literal["raise", "keep"] = "raise",
    tables: Any = None,
) -> list:
    """Watertight meshes of several oriented clouds, one jitted solve per point bucket.

    A view's mesh does not depend on the other views of the batch (bit for bit on the CPU).

    Args:
        views: :class:`~symjax.surface.normals.OrientedPoints` or ``(points (N_i, 3), normals
            (N_i, 3)[, weights (N_i,)])`` tuples, one per view.
        config: :class:`PoissonConfig`, shared by the views.
        execution: ``poisson_chunk_views`` views are solved at once; no effect on the result.
        errors: ``"raise"``: the first bad view raises. ``"keep"``: a bad view's entry is its
            :class:`~symjax.errors.SymjaxError` and the other views are meshed as if alone.
        tables: One :class:`~symjax.table.TablePlane` for every view, one per view (a list,
            None entries allowed), or None: the surfaces are cut at their table (see
            :func:`poisson_reconstruct`).

    Returns:
        One ``trimesh.Trimesh`` per view, in order (or the view's error, with ``"keep"``).
    """
    cfg = config_or_default(config, PoissonConfig)
    ex = config_or_default(execution, ExecutionConfig, "execution")
    if errors not in ("raise", "keep"):
        raise InvalidInputError(f"errors must be 'raise' or 'keep', got {errors!r}")
    views = list(views)
    if not views:
        raise InvalidInputError("views is empty; expected at least one oriented cloud")
    triples = [_as_triple(v) for v in views]
    if tables is None or not isinstance(tables, (list, tuple)):
        tables = [tables] * len(views)
    if len(tables) != len(views):
        raise InvalidInputError(f"{len(tables)} tables for {len(views)} views; expected one each")
    tables = [_check_table(t) for t in tables]
    out: list = [None] * len(views)
    # Each view keeps its own point bucket, so its rounding never depends on the batch; views
    # of one bucket share calls.
    groups: dict[int, list[int]] = {}  # point bucket -> views
    packed: dict[int, tuple] = {}
    for i, t in enumerate(triples):
        try:
            n = cloud_bucket(max(len(t[0]), 1))
            packed[i] = pack_views([t], cfg, n)
            groups.setdefault(n, []).append(i)
        except SymjaxError as e:
            if errors == "raise":
                raise
            out[i] = e
    if ex.poisson_chunk_views == 1:
        _one_by_one(packed, cfg, tables, errors, out)
        return out
    # Every call solves exactly one chunk of views, the last one filled with copies of its
    # first view: one compiled shape per point bucket, whatever the group sizes of a sequence
    # of batches. All calls are dispatched before the first grid is read.
    calls = []
    for idx in groups.values():
        width = max(2, ex.poisson_chunk_views or len(idx))
        for s in range(0, len(idx), width):
            part = idx[s : s + width]
            rows = part + [part[0]] * (width - len(part))
            arrays = [np.concatenate([packed[i][k] for i in rows]) for k in range(4)]
            calls.append((part, solve_grids(*arrays, cfg, width)))
    for part, grids in calls:
        grids = jax.device_get(grids)
        for j, i in enumerate(part):
            out[i] = _mesh_or_error(grids[j], packed[i], cfg, tables[i], errors)
    return out


def _one_by_one(packed: dict, cfg: PoissonConfig, tables: list, errors: str, out: list) -> None:
    """Solves and meshes each view with the single-view kernel, several views at a time in
    threads (:func:`symjax._threads.map_in_threads`: 2 cores, 44 against 69 ms a view vmapped),
    each meshed as soon as it is solved."""

    def job(i: int):
        P, N, W, V = packed[i]
        grid = jax.device_get(solve_grid(P[0], N[0], W[0], V[0], cfg))
        return _mesh_or_error(grid, packed[i], cfg, tables[i], "keep")

    order = list(packed)
    for i, mesh in zip(order, map_in_threads(job, order), strict=True):
        if isinstance(mesh, SymjaxError) and errors == "raise":
            raise mesh
        out[i] = mesh


def _mesh_or_error(grid, packed: tuple, cfg: PoissonConfig, table, errors: str):
    try:
        return _mesh(grid, packed, cfg, table)
    except SymjaxError as e:
        if errors == "raise":
            raise
        return e
