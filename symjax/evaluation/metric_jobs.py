"""The evaluation's metrics (deviation and centroid error of each mesh against the truth), run in
the evaluating process or in worker processes.

The metrics are host code that holds the GIL (libigl's AABB tree, numpy), about a third of the
evaluation's time, while the rest of the evaluation leaves a core idle (the search and the
Poisson solve wait on XLA, the marching cubes on one core). Workers measure the meshes of one
batch while the next batch is searched and meshed. A worker computes exactly what the evaluating
process would: the same arrays, the same libraries, the same seed.
"""

from __future__ import annotations

import time
from concurrent.futures import Future, ProcessPoolExecutor
from typing import Any

import numpy as np

from symjax.errors import SymjaxError, one_line
from symjax.evaluation.records import MeshResult

__all__ = ["MetricRunner", "measure"]


def measure(method: str, truth, mesh, n_samples: int, diagonal: float | None) -> MeshResult:
    """Deviation statistics (mm) and centroid error of one mesh against the true mesh.

    Args:
        method: The reconstruction's name (``"Del"``, ``"Mir5"``, ``"Mir7"``).
        truth: The true ``trimesh.Trimesh`` (world frame), or None: only the face count.
        mesh: The reconstruction.
        n_samples: Uniform samples of the true surface (MeshDev's sampling).
        diagonal: The truth's oriented-box diagonal, metres, or None (computed).
    """
    from symjax.metrics import centroid_error, mesh_deviation

    if truth is None:
        return MeshResult(method, True, n_faces=int(len(mesh.faces)))
    try:
        dev = mesh_deviation(truth, mesh, n_samples=n_samples)
        centroid = centroid_error(truth, mesh, diagonal=diagonal)
    except SymjaxError as e:
        return MeshResult(method, False, error=one_line(e), n_faces=int(len(mesh.faces)))
    return MeshResult(
        method,
        True,
        n_faces=int(len(mesh.faces)),
        dev_mean_mm=1e3 * dev.mean,
        dev_var_mm2=1e6 * dev.variance,
        dev_max_mm=1e3 * dev.max,
        dev_p50_mm=1e3 * dev.percentiles[50],
        dev_p95_mm=1e3 * dev.percentiles[95],
        centroid_error=centroid,
    )


def _arrays(mesh) -> tuple[np.ndarray, np.ndarray] | None:
    if mesh is None:
        return None
    return np.asarray(mesh.vertices, np.float64), np.asarray(mesh.faces, np.int64)


def _measure_arrays(method: str, truth, mesh, n_samples: int, diagonal) -> tuple[MeshResult, float]:
    """:func:`measure` on ``(vertices, faces)`` pairs, timed (the worker's entry point)."""
    import trimesh

    t0 = time.perf_counter()

    def rebuilt(vf):
        return None if vf is None else trimesh.Trimesh(vf[0], vf[1], process=False)

    res = measure(method, rebuilt(truth), rebuilt(mesh), n_samples, diagonal)
    return res, time.perf_counter() - t0


def _cpu_only() -> None:
    """Worker initializer: the metrics are host code, and a worker that started JAX on a GPU
    would take the device's memory (XLA preallocates 75 % per process), so the evaluating process
    and eight workers of the ``gpu`` preset ran out of it on an H200 (2026-12-04)."""
    import os

    os.environ["JAX_PLATFORMS"] = "cpu"
    import jax

    jax.config.update("jax_platforms", "cpu")


class _Done:
    """A result computed in the evaluating process, with the interface of a ``Future``."""

    def __init__(self, value: Any) -> None:
        self._value = value

    def result(self) -> Any:
        return self._value


class MetricRunner:
    """Runs :func:`measure` in ``workers`` processes (0: in this process, when called).

    A context manager: the workers start on entry (spawned, so they share no JAX state with
    this process; JAX on the CPU only, leaving an accelerator to this process) and stop on exit,
    pending jobs cancelled.
    """

    def __init__(self, workers: int = 0) -> None:
        self.workers = int(workers)
        self._pool: ProcessPoolExecutor | None = None

    def __enter__(self) -> MetricRunner:
        if self.workers > 0:
            import multiprocessing

            self._pool = ProcessPoolExecutor(
                self.workers,
                mp_context=multiprocessing.get_context("spawn"),
                initializer=_cpu_only,
            )
        return self

    def __exit__(self, *exc) -> None:
        if self._pool is not None:
            self._pool.shutdown(wait=exc[0] is None, cancel_futures=True)
            self._pool = None

    def submit(
        self, method: str, truth, mesh, n_samples: int, diagonal: float | None
    ) -> Future | _Done:
        """Measures one mesh; ``.result()`` gives ``(MeshResult, seconds)``."""
        if self._pool is None:
            t0 = time.perf_counter()
            res = measure(method, truth, mesh, n_samples, diagonal)
            return _Done((res, time.perf_counter() - t0))
        return self._pool.submit(
            _measure_arrays, method, _arrays(truth), _arrays(mesh), n_samples, diagonal
        )
