"""The evaluation's metrics in a worker process give what the evaluating process gives."""

from __future__ import annotations

import numpy as np
import trimesh

from symjax.evaluation.metric_jobs import MetricRunner, measure
from symjax.metrics import centroid_error, oriented_diagonal


def _meshes():
    truth = trimesh.creation.box([0.08, 0.05, 0.12])
    truth.apply_transform(trimesh.transformations.rotation_matrix(0.4, [0, 0, 1]))
    mesh = trimesh.creation.icosphere(3, radius=0.06)
    mesh.apply_scale([0.7, 0.5, 1.0])
    return truth, mesh


def _worker_platforms() -> str:
    """The JAX platforms a worker process may use."""
    import jax

    return str(jax.config.jax_platforms)


def test_worker_measures_what_the_process_measures():
    truth, mesh = _meshes()
    with MetricRunner(0) as inline:
        here, _ = inline.submit("Mir7", truth, mesh, 500, None).result()
    with MetricRunner(1) as pool:
        there, seconds = pool.submit("Mir7", truth, mesh, 500, None).result()
        # A worker must leave an accelerator to the evaluating process (GPU memory).
        platforms = pool._pool.submit(_worker_platforms).result()
    assert here == there and here.ok and seconds > 0
    assert platforms == "cpu"
    assert measure("Mir7", None, mesh, 500, None).n_faces == len(mesh.faces)


def test_shared_diagonal_is_the_pose_free_box():
    truth, mesh = _meshes()
    d = oriented_diagonal(truth)
    np.testing.assert_allclose(d, np.linalg.norm([0.08, 0.05, 0.12]), rtol=1e-9)
    assert centroid_error(truth, mesh, 500, diagonal=d) == centroid_error(truth, mesh, 500)
