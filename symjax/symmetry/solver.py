"""Entry points of the symmetry search: one view, a batch of views in one jitted call, and the
completed clouds.

All hypotheses of a view are scored by one ``vmap`` of a per-hypothesis kernel; all views of a
batch by ``lax.map`` (chunks of ``vmap``) inside the same ``jit``.
"""

from __future__ import annotations

import functools
from collections.abc import Sequence

import jax
import jax.numpy as jnp
import numpy as np

from symjax.errors import InvalidInputError, config_or_default
from symjax.execution import ExecutionConfig
from symjax.geometry import bucket
from symjax.observation import Observation
from symjax.symmetry.config import SymmetryConfig
from symjax.symmetry.hypotheses import search_view
from symjax.symmetry.result import SymmetryResult
from symjax.symmetry.view import ViewArrays, prepare_view

__all__ = ["complete", "search", "search_batch"]


@functools.partial(jax.jit, static_argnums=(1, 2))
def _search_jit(view: ViewArrays, cfg: SymmetryConfig, chunk_planes: int) -> SymmetryResult:
    return search_view(view, cfg, jnp.isfinite(view.points).all(), chunk_planes)


@functools.partial(jax.jit, static_argnums=(1, 2, 3))
def _search_batch_jit(
    views: ViewArrays, cfg: SymmetryConfig, chunk: int, chunk_planes: int
) -> SymmetryResult:
    # lax.map with batch_size vmaps chunks of views: every hypothesis of a chunk in one vmap,
    # while memory stays bounded for 128 views x 40k points.
    gate = jnp.isfinite(views.points).all()
    return jax.lax.map(lambda v: search_view(v, cfg, gate, chunk_planes), views, batch_size=chunk)


def search(
    obs: Observation,
    config: SymmetryConfig | None = None,
    execution: ExecutionConfig | None = None,
) -> SymmetryResult:
    """Finds the reflection symmetry plane perpendicular to the table of one view.

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
    """
    cfg = config_or_default(config, SymmetryConfig)
    ex = config_or_default(execution, ExecutionConfig, "execution")
    if not isinstance(obs, Observation):
        raise InvalidInputError(f"search expects a symjax.Observation, got {type(obs).__name__}")
    view = prepare_view(obs, bucket(len(np.asarray(obs.points))))
    return _search_jit(view, cfg, ex.symmetry_chunk_hypotheses)


def search_batch(
    observations: Sequence[Observation],
    config: SymmetryConfig | None = None,
    execution: ExecutionConfig | None = None,
) -> SymmetryResult:
    """Searches all hypotheses of all views in one jitted call.

    Views are padded to a common number of points (:func:`symjax.geometry.bucket`) and
    image size, then scored by ``lax.map`` over chunks of ``execution.symmetry_chunk_views``
    views, each chunk one ``vmap``.

    Args:
        observations: Single-view observations.
        config: Search parameters (default :class:`SymmetryConfig`).
        execution: Chunk sizes; no effect on the result.

    Returns:
        A batched :class:`SymmetryResult` (leading axis = view; ``result[i]`` is view i).
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
    n = bucket(max(len(np.asarray(o.points)) for o in observations))
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
    chunk = ex.symmetry_chunk_views if ex.symmetry_chunk_views > 0 else len(padded)
    return _search_batch_jit(stacked, cfg, min(chunk, len(padded)), ex.symmetry_chunk_hypotheses)


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
    """
    if isinstance(observations, Observation):
        observations = [observations]
    res = search_batch(observations, config, execution)
    return [res[i].completed_cloud() for i in range(len(res))]
