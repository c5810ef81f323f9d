"""Entry points of the symmetry search: one view, a batch of views in one jitted call, and the
completed clouds.

All hypotheses of a view are scored by one ``vmap`` of a per-hypothesis kernel; all views of a
batch by ``lax.map`` (chunks of ``vmap``) inside the same ``jit``.
"""

from __future__ import annotations

import dataclasses
import functools
from collections.abc import Sequence

import jax
import jax.numpy as jnp
import numpy as np

from symjax._kernel_store import StoredKernel
from symjax._threads import map_in_threads
from symjax.errors import (
    DegenerateGeometryError,
    InvalidInputError,
    SymjaxError,
    config_or_default,
)
from symjax.execution import ExecutionConfig
from symjax.geometry import cloud_bucket, reflect
from symjax.observation import Observation
from symjax.symmetry.config import SymmetryConfig
from symjax.symmetry.hypotheses import mirror_view, search_view
from symjax.symmetry.result import SymmetryResult
from symjax.symmetry.view import ViewArrays, aligned_stack, prepare_view

__all__ = ["complete", "mirror_across", "search", "search_batch", "search_or_errors"]


def _search_one(view: ViewArrays, cfg: SymmetryConfig, chunk_planes: int) -> SymmetryResult:
    return search_view(view, cfg, jnp.isfinite(view.points).all(), chunk_planes)


# Stored as exported StableHLO: a new process's first view skips the tracing (symjax._kernel_store).
_search_jit = StoredKernel(_search_one, (1, 2), "_search_jit")


@functools.partial(jax.jit, static_argnums=(1, 2, 3))
def _search_batch_jit(
    views: ViewArrays, cfg: SymmetryConfig, chunk: int, chunk_planes: int
) -> SymmetryResult:
    # lax.map with batch_size vmaps chunks of views: every hypothesis of a chunk in one vmap,
    # while memory stays bounded for 128 views x 40k points.
    gate = jnp.isfinite(views.points).all()
    occluded = views.occluded.any()
    return jax.lax.map(
        lambda v: search_view(v, cfg, gate, chunk_planes, occluded), views, batch_size=chunk
    )


def _checked_plane(res: SymmetryResult) -> None:
    n = np.asarray(res.normal, np.float64)
    if not (np.all(np.isfinite(n)) and abs(np.linalg.norm(n) - 1.0) < 1e-3):
        raise DegenerateGeometryError(
            f"the search found no plane for this view (normal {n.tolist()}); the view is"
            " degenerate (too few distinct points or no spread)"
        )
    if not (np.isfinite(float(res.offset)) and np.isfinite(float(res.vote))):
        raise DegenerateGeometryError("the best plane has a NaN offset or vote; degenerate view")


def search(
    obs: Observation,
    config: SymmetryConfig | None = None,
    execution: ExecutionConfig | None = None,
) -> SymmetryResult:
    """Finds the reflection symmetry plane perpendicular to the table of one view.

    The unbatched kernel: :func:`search_batch` gives the same result bit for bit at the default
    ``symmetry_chunk_views=1``, and agrees to float32 rounding (about 1e-6 in the normal) with
    a vmapped chunk.

    Args:
        obs: One observation (points padded to any size; images of the camera's size).
        config: Search parameters (default :class:`SymmetryConfig`; the paper's exact search is
            the ``paper`` preset, ``symjax.configs.load("paper").symmetry``).
        execution: Chunk sizes (:class:`symjax.execution.ExecutionConfig`); no effect on the
            result.

    Returns:
        A :class:`SymmetryResult` (arrays without a batch axis).

    Raises:
        InvalidInputError: Bad observation (see :meth:`symjax.Observation.create`).
        DegenerateGeometryError: The view has no spread on the table, or no plane was found.
    """
    cfg = config_or_default(config, SymmetryConfig)
    ex = config_or_default(execution, ExecutionConfig, "execution")
    if not isinstance(obs, Observation):
        raise InvalidInputError(f"search expects a symjax.Observation, got {type(obs).__name__}")
    view = prepare_view(obs, cloud_bucket(len(np.asarray(obs.points))))
    res = _search_jit(view, cfg, ex.symmetry_chunk_hypotheses)
    _checked_plane(res)
    return res


def _run_group(views: list[ViewArrays], cfg: SymmetryConfig, ex: ExecutionConfig) -> list:
    """Single-view results of views with one image shape and one point bucket.

    Every call scores exactly one chunk of views (``symmetry_chunk_views`` >= 2; 0 = the whole
    group in one call), the last chunk filled with copies of the first view: XLA's rounding
    can change with the vmap width, so one width is what makes a view's result independent of
    its batch, and one call shape per point bucket is what keeps a sequence of batches from
    compiling again for every group size. The calls are dispatched before any result is read.
    """
    chunk = max(2, ex.symmetry_chunk_views if ex.symmetry_chunk_views > 0 else len(views))
    padded = views + [views[0]] * ((-len(views)) % chunk)
    calls = []
    for s in range(0, len(padded), chunk):
        # Stacked on the host: jnp.stack would compile a small program for every new shape.
        stacked = jax.tree_util.tree_map(lambda *xs: aligned_stack(xs), *padded[s : s + chunk])
        calls.append(_search_batch_jit(stacked, cfg, chunk, ex.symmetry_chunk_hypotheses))
    out = []
    for res in jax.device_get(calls):
        out.extend(jax.tree_util.tree_map(lambda x, i=i: x[i], res) for i in range(chunk))
    return out[: len(views)]


def _one_by_one(observations: list, cfg: SymmetryConfig, ex: ExecutionConfig, errors: list):
    """Host results of the single-view kernel, several views at a time in threads
    (:func:`symjax._threads.map_in_threads`; 128 benchmark views on 2 cores: 1.32 s against
    1.74 s dispatched in turn)."""

    def job(o: Observation):
        try:
            v = prepare_view(o, cloud_bucket(len(np.asarray(o.points))))
        except SymjaxError as e:
            return e
        return jax.device_get(_search_jit(v, cfg, ex.symmetry_chunk_hypotheses))

    results = {}
    for i, r in enumerate(map_in_threads(job, observations)):
        if isinstance(r, SymjaxError):
            errors[i] = r
        else:
            results[i] = r
    return results


def search_batch(
    observations: Sequence[Observation],
    config: SymmetryConfig | None = None,
    execution: ExecutionConfig | None = None,
) -> SymmetryResult:
    """Searches all hypotheses of all views, one jitted call per image size and point bucket.

    Each view is padded to its own point bucket (:func:`symjax.geometry.cloud_bucket`). With
    ``execution.symmetry_chunk_views == 1`` (the default, for a CPU) each view is one call of
    the kernel :func:`search` runs, several views side by side in threads (one per core, at
    most 8), and its result is ``search(obs)``'s bit for bit. With a chunk of
    ``c >= 2`` (a GPU) views that share an image size and a bucket are scored ``c`` at a time
    by one ``vmap``. A view that cannot be searched (NaN points, no spread, no plane found) does not
    stop the batch: ``result.ok[i]`` is False, ``result.errors[i]`` says why, its float fields
    are NaN and ``result[i]`` raises. Each view's result is independent of the other views of
    the batch, bit for bit on the CPU.

    Args:
        observations: Single-view observations.
        config: Search parameters (default :class:`SymmetryConfig`).
        execution: Chunk sizes; no effect on the result.

    Returns:
        A batched :class:`SymmetryResult` of numpy arrays, already on the host (leading axis =
        view; ``result[i]`` is view i, indexed without a device round trip).

    Raises:
        InvalidInputError: Not a sequence of Observations, or no view could be searched.
    """
    cfg = config_or_default(config, SymmetryConfig)
    ex = config_or_default(execution, ExecutionConfig, "execution")
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
    errors: list[SymjaxError | None] = [None] * len(observations)
    views: dict[int, ViewArrays] = {}  # packed, for the vmapped chunks
    results: dict[int, SymmetryResult] = {}  # dispatched
    if ex.symmetry_chunk_views == 1:
        results = _one_by_one(observations, cfg, ex, errors)
    else:
        for i, o in enumerate(observations):
            try:
                views[i] = prepare_view(o, cloud_bucket(len(np.asarray(o.points))))
            except SymjaxError as e:
                errors[i] = e
    if not views and not results:
        raise InvalidInputError(
            "no view of the batch could be searched: "
            + "; ".join(f"view {i}: {e}" for i, e in enumerate(errors))
        )
    # Views of one image size and one point bucket share a call: each view keeps the shapes it
    # has alone, so float rounding never depends on the rest of the batch.
    groups: dict[tuple[int, int, int], list[int]] = {}
    for i, v in views.items():
        groups.setdefault((*v.image.shape[:2], int(v.points.shape[0])), []).append(i)
    for idx in groups.values():
        # Neighbours by point count share a vmap: the kernel's loop runs to the larger one's
        # last point, so pairing 4,000 with 8,000 points would score the first twice over.
        idx = sorted(idx, key=lambda i: int(np.sum(np.asarray(views[i].valid))))
        results.update(zip(idx, _run_group([views[i] for i in idx], cfg, ex), strict=True))
    single: dict[int, SymmetryResult] = {}
    for i, r in zip(results, jax.device_get(list(results.values())), strict=True):
        try:
            _checked_plane(r)
            single[i] = r
        except SymjaxError as e:
            errors[i] = e
    if not single:
        raise InvalidInputError(
            "no view of the batch has a plane: "
            + "; ".join(f"view {i}: {e}" for i, e in enumerate(errors) if e is not None)
        )
    return stack_results(single, errors)


def stack_results(single: dict, errors: Sequence) -> SymmetryResult:
    """A batched result of single-view results: ``single`` maps view index to its host
    :class:`SymmetryResult` (at least one), ``errors`` (one per view) says why the others have
    none. Point arrays are padded to the longest view's."""
    n = max(int(np.shape(r.points)[0]) for r in single.values())
    template = next(iter(single.values()))
    rows = [_fit(single.get(i), template, n) for i in range(len(errors))]
    stacked = jax.tree_util.tree_map(lambda *xs: np.stack(xs), *rows)
    return dataclasses.replace(
        stacked, errors=tuple(errors) if any(e is not None for e in errors) else None
    )


def _fit(res: SymmetryResult | None, template: SymmetryResult, n: int) -> SymmetryResult:
    """One row of a batched result: point arrays padded to ``n`` rows; a failed view is NaN."""
    src = template if res is None else res
    rows = int(np.shape(src.points)[0])
    point_fields = {"points", "valid", "mirrored", "mirrored_keep", "plausibility"}
    values = {}
    for f in dataclasses.fields(src):
        if f.name == "errors":
            continue
        x = np.asarray(getattr(src, f.name))
        if res is None:
            x = np.full_like(x, np.nan) if x.dtype.kind == "f" else np.zeros_like(x)
        if f.name in point_fields and rows < n:
            pad = np.zeros((n - rows, *x.shape[1:]), x.dtype)
            if f.name == "mirrored":  # padding points sit at the origin; keep mirrored = reflected
                normal = np.asarray(src.normal, x.dtype)
                pad = np.asarray(reflect(pad, normal, np.asarray(src.offset, x.dtype)), x.dtype)
                if res is None:
                    pad[:] = np.nan
            x = np.concatenate([x, pad])
        values[f.name] = x
    return SymmetryResult(**values)


def complete(
    observations: Observation | Sequence[Observation],
    config: SymmetryConfig | None = None,
    execution: ExecutionConfig | None = None,
) -> list[np.ndarray]:
    """Completed clouds by symmetry: the observed points plus the kept mirrored points.

    Args:
        observations: One observation or a sequence of them (searched in one batch).
        config: Search parameters.
        execution: Chunk sizes; no effect on the result.

    Returns:
        One ``(M_i, 3)`` float array per view, metres, world frame; a single observation gives
        a list of one. Use :func:`search_batch` for the planes and votes.

    Raises:
        SymjaxError: A view could not be completed (the batch's error for that view).
    """
    if isinstance(observations, Observation):
        observations = [observations]
    res = search_batch(observations, config, execution)
    return [res[i].completed_cloud() for i in range(len(res))]


_mirror_jit = jax.jit(mirror_view, static_argnums=3)


def mirror_across(
    result: SymmetryResult,
    obs: Observation,
    normal: np.ndarray,
    offset: float,
    config: SymmetryConfig | None = None,
) -> SymmetryResult:
    """The view's completion across another plane than the one its search found.

    The points are mirrored, kept and weighted as the search does for its best plane (one
    jitted call per point bucket); the plane's fields are replaced, the search's votes kept.

    Args:
        result: A single-view :class:`SymmetryResult` of ``obs`` (its point padding is kept).
        obs: The observation it was searched on.
        normal: (3,) plane normal (normalised here); offset: the plane's offset, metres.
        config: The search's parameters (tolerance, plausibility scales).

    Returns:
        A :class:`SymmetryResult` whose ``normal``, ``offset``, ``mirrored``, ``mirrored_keep``
        and ``plausibility`` are those of the given plane.

    Raises:
        ShapeError: ``result`` is a batch.
        InvalidInputError: The normal is not finite or is zero.
    """
    from symjax.errors import ShapeError

    cfg = config_or_default(config, SymmetryConfig)
    if np.ndim(result.points) != 2:
        raise ShapeError("mirror_across() needs one view; index the batch first: result[i]")
    n = np.asarray(normal, np.float64).reshape(-1)
    norm = float(np.linalg.norm(n)) if n.shape == (3,) else 0.0
    if not (np.isfinite(norm) and norm > 1e-9 and np.isfinite(offset)):
        raise InvalidInputError(f"plane normal {n.tolist()} / offset {offset}: expected a finite"
                                " non-zero (3,) normal and a finite offset")  # fmt: skip
    view = prepare_view(obs, int(np.shape(result.points)[0]))
    n32 = np.asarray(n / norm, np.float32)
    mirrored, keep, plaus = _mirror_jit(view, n32, np.float32(offset), cfg)
    return dataclasses.replace(
        result, normal=n32, offset=np.float32(offset), mirrored=np.asarray(mirrored),
        mirrored_keep=np.asarray(keep), plausibility=np.asarray(plaus),
    )  # fmt: skip


def search_or_errors(
    observations: Sequence[Observation],
    config: SymmetryConfig | None = None,
    execution: ExecutionConfig | None = None,
    search: SymmetryResult | None = None,
) -> tuple[SymmetryResult | None, list]:
    """The batched search of the observations (or ``search``, when the caller ran it), and per
    view None or the :class:`SymjaxError` that kept it from a plane: the entry of the stages
    that go on with the other views when one fails.

    Returns:
        ``(result or None, errors)``: None and the batch's error for every view when the batch
        as a whole failed.
    """
    n = len(observations)
    try:
        res = search if search is not None else search_batch(list(observations), config, execution)
    except SymjaxError as e:
        return None, [e] * n
    errors = [
        None if bool(res.ok[i])
        else res.errors[i] if res.errors and res.errors[i] is not None
        else DegenerateGeometryError("the search found no plane for this view")
        for i in range(n)
    ]  # fmt: skip
    return res, errors
