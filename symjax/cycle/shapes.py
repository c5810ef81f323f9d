"""``PredictObjectShape`` and ``ConvexDecomposition`` for every hypothesis of a frame.

``C``: one batched symmetry search over all hypotheses, each completed as
:func:`symjax.completion.choose_completion` chooses (mirror or revolution), one batched Poisson
solve cut at the table (the paper's Mir7). ``P``: the paper's Delaunay
baseline of the observed points, cut at the table. ``T``: the true meshes (given). A hypothesis
that fails keeps its error; the others go on.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from symjax.cycle.config import CycleConfig
from symjax.errors import DegenerateGeometryError, SymjaxError

__all__ = [
    "baseline_meshes",
    "completed_meshes",
    "cut_at_table",
    "decompose_shapes",
    "predict_shapes",
]


def completed_meshes(observations: list, tables: list, cfg: Any, search: Any = None) -> list:
    """The paper's Mir7 per observation: one batched symmetry search, each view's completion
    (:func:`~symjax.completion.choose_completion`), one batched Poisson solve, each mesh cut at
    its table (and at its points' hull, ``poisson.clip_to_hull``).

    Args:
        observations: :class:`symjax.Observation` list.
        tables: The table plane each stands on.
        cfg: A config with ``symmetry``, ``completion``, ``normals``, ``poisson`` and ``execution``
            (:class:`~symjax.configs.stages.ShapeToGraspStages`).
        search: The batched :class:`~symjax.symmetry.SymmetryResult` of ``observations`` when
            the caller ran the search (and keeps its planes); None runs it here.

    Returns:
        Per observation a ``trimesh.Trimesh`` (world frame) or the :class:`SymjaxError`.
    """
    from symjax.completion import choose_completion
    from symjax.surface import poisson_reconstruct_batch
    from symjax.symmetry import search_or_errors

    res, out = search_or_errors(observations, cfg.symmetry, cfg.execution, search)
    ops, good = [], []
    for i, obs in enumerate(observations):
        if out[i] is not None:
            continue
        try:
            c = choose_completion(res[i], obs, cfg.completion, cfg.normals, cfg.symmetry)
        except SymjaxError as e:
            out[i] = e
            continue
        if c.mesh is not None:  # the fallback is a mesh already
            out[i] = c.mesh
        else:
            ops.append(c.oriented)
            good.append(i)
    if ops:
        meshes = poisson_reconstruct_batch(ops, cfg.poisson, cfg.execution, errors="keep",
                                           tables=[tables[i] for i in good])  # fmt: skip
        for i, m in zip(good, meshes, strict=True):
            out[i] = m
    return out


def cut_at_table(mesh: Any, table: Any) -> Any:
    """The mesh with every vertex below the table moved onto it: still closed, flat below.

    (The baseline's back sheet is pushed along the viewing rays, which point down through
    the table.)
    """
    import trimesh

    n = np.asarray(table.normal, float)
    n = n / np.linalg.norm(n)
    v = np.asarray(mesh.vertices, float)
    h = v @ n + float(table.offset) / np.linalg.norm(table.normal)
    if np.all(h <= 1e-4):
        raise DegenerateGeometryError("nothing of the mesh is above the table")
    v = v - np.minimum(h, 0.0)[:, None] * n
    return trimesh.Trimesh(v, np.asarray(mesh.faces), process=False)


def baseline_meshes(observations: list, tables: list, cfg: Any) -> list:
    """The paper's Delaunay baseline of each observation's points (``cfg.delaunay``), cut at
    its table: a ``trimesh.Trimesh`` or the :class:`SymjaxError` per observation."""
    from symjax.surface import delaunay_mesh

    out: list = []
    for obs, table in zip(observations, tables, strict=True):
        try:
            out.append(cut_at_table(delaunay_mesh(obs.valid_points(), obs.camera, cfg.delaunay),
                                    table))  # fmt: skip
        except SymjaxError as e:
            out.append(e)
    return out


def predict_shapes(ts: Any, cfg: CycleConfig, truth: list | None = None) -> list:
    """One mesh (``trimesh.Trimesh``, world frame) or the :class:`SymjaxError` per hypothesis;
    in mode ``K`` one :class:`~symjax.completion.ShapeSet` (or the error).

    Args:
        ts: The frame's :class:`symjax.perception.TableScene`.
        cfg: The cycle's config (its ``mode`` picks the shape).
        truth: For ``T``: per hypothesis the matched true mesh, or None (unmatched).
    """
    if cfg.mode == "K":
        from symjax.completion import plausible_shapes

        return plausible_shapes(ts.objects, cfg, _frame_search(ts.objects, cfg))
    if cfg.mode == "C":
        tables = [ts.table] * len(ts.objects)
        return completed_meshes(ts.objects, tables, cfg, _frame_search(ts.objects, cfg))
    if cfg.mode == "P":
        return baseline_meshes(ts.objects, [ts.table] * len(ts.objects), cfg)
    return [
        m if m is not None else DegenerateGeometryError("the hypothesis is no true object")
        for m in (truth or [None] * len(ts.objects))
    ]


def _frame_search(objects: tuple, cfg: CycleConfig) -> Any:
    """The frame's hypotheses searched together against their neighbours' completed volumes
    (:func:`symjax.symmetry.search_scene`) when ``cfg.symmetry.neighbour_volumes`` asks for it;
    None otherwise, or when that batch fails (the per-view search then says which view and
    why)."""
    if not objects or not cfg.symmetry.neighbour_volumes:
        return None
    from symjax.symmetry import search_scene

    try:
        return search_scene(objects, cfg.symmetry, cfg.execution)
    except SymjaxError:
        return None


def decompose_shapes(meshes: list, cfg: CycleConfig, truth: list | None = None) -> list:
    """A :class:`symjax.decompose.Decomposition` (or the error) per predicted shape.

    ``truth`` (mode ``T``) gives the decompositions directly.
    """
    from symjax.decompose import decompose

    if truth is not None:
        return [t if t is not None else m for t, m in zip(truth, meshes, strict=True)]
    out = []
    for m in meshes:
        if isinstance(m, SymjaxError):
            out.append(m)
            continue
        try:
            out.append(decompose(m, cfg.decompose))
        except SymjaxError as e:
            out.append(e)
    return out
