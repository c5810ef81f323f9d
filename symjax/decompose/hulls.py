"""Convex decomposition of a triangle mesh with coacd, capped hulls and a disk cache.

The paper (Section IV) replaces the reconstructed mesh by convex pieces before simulation
(``ConvexDecomposition``); collision checks between convex hulls are what MJX does fast.
"""

from __future__ import annotations

import dataclasses
import hashlib
import io
import os
import time
import zipfile
from pathlib import Path

import numpy as np
from scipy.spatial import ConvexHull, QhullError

from symjax import resources
from symjax._atomic import atomic_write_bytes
from symjax.array_types import ArrayLike, MeshLike
from symjax.decompose.config import DecomposeConfig
from symjax.errors import DegenerateGeometryError, FileFormatError
from symjax.geometry import is_closed, mesh_arrays

__all__ = ["Decomposition", "cap_hull", "decompose", "default_cache_dir", "mesh_key", "simplify"]

_CACHE_VERSION = "2"  # 2: meshes simplified before coacd


@dataclasses.dataclass(frozen=True)
class Decomposition:
    """Convex pieces of a mesh.

    Attributes:
        hulls: Per hull ``(vertices (V, 3) metres, faces (F, 3) int)``; every hull convex, with
            at most ``config.max_vertices`` vertices.
        key: The cache key (hash of the mesh and the settings).
        cache_hit: Whether the hulls were read from the disk cache.
        seconds: Wall time of this call.
    """

    hulls: tuple[tuple[np.ndarray, np.ndarray], ...]
    key: str
    cache_hit: bool
    seconds: float

    @property
    def n_hulls(self) -> int:
        return len(self.hulls)

    def transformed(self, pose: ArrayLike) -> Decomposition:
        """The same hulls moved rigidly: no new decomposition, the cache is not consulted.

        Args:
            pose: A (4, 4) homogeneous transform or ``(x, y, z, qw, qx, qy, qz)``, metres.

        Returns:
            A :class:`Decomposition` with the moved hulls; its key is this key and the pose's.
        """
        from symjax.geometry import as_pose

        p, R = as_pose(pose, "decomposition pose")
        hulls = tuple((v @ R.T + p, f.copy()) for v, f in self.hulls)
        h = hashlib.sha256(self.key.encode())
        h.update(np.concatenate([p, R.ravel()]).astype(np.float64).tobytes())
        return Decomposition(hulls, h.hexdigest(), self.cache_hit, 0.0)


def default_cache_dir() -> Path:
    """``$SYMJAX_CACHE/coacd``, else ``~/.cache/symjax/coacd`` (:mod:`symjax.resources`)."""
    return resources.cache_dir("coacd")


def mesh_key(mesh: MeshLike, config: DecomposeConfig | None = None) -> str:
    """SHA-256 of the mesh (float64 vertices, int64 faces) and the settings."""
    config = config if config is not None else DecomposeConfig()
    v, f = mesh_arrays(mesh)
    h = hashlib.sha256()
    h.update(_CACHE_VERSION.encode())
    h.update(repr(dataclasses.astuple(config)).encode())
    h.update(v.tobytes())
    h.update(f.tobytes())
    return h.hexdigest()


def cap_hull(points: ArrayLike, max_vertices: int) -> tuple[np.ndarray, np.ndarray]:
    """Convex hull of ``points`` with at most ``max_vertices`` vertices.

    Hull vertices beyond the cap are thinned by farthest-point sampling (which keeps the
    extremes, so the capped hull stays close to the original), then the hull is recomputed.

    Returns:
        ``(vertices (V, 3), faces (F, 3))`` with outward-wound faces.

    Raises:
        DegenerateGeometryError: The points are (nearly) coplanar.
    """
    p = np.asarray(points, dtype=np.float64)
    try:
        hull = ConvexHull(p)
        v = p[hull.vertices]
        if len(v) > max_vertices:
            idx = [int(np.argmax(np.linalg.norm(v - v.mean(0), axis=1)))]
            dist = np.linalg.norm(v - v[idx[0]], axis=1)
            for _ in range(max_vertices - 1):
                idx.append(int(np.argmax(dist)))
                dist = np.minimum(dist, np.linalg.norm(v - v[idx[-1]], axis=1))
            v = v[idx]
        hull = ConvexHull(v)
    except QhullError as e:
        raise DegenerateGeometryError(f"points span no volume: {e}") from None
    v = v[hull.vertices]
    hull = ConvexHull(v)
    faces = hull.simplices.copy()
    # Qhull does not orient simplices; wind each face so its normal points away from the centre.
    c = v.mean(0)
    a, b, cc = v[faces[:, 0]], v[faces[:, 1]], v[faces[:, 2]]
    flip = np.einsum("ij,ij->i", np.cross(b - a, cc - a), a - c) < 0
    faces[flip] = faces[flip][:, ::-1]
    return v, faces


def simplify(v: np.ndarray, f: np.ndarray, max_faces: int) -> tuple[np.ndarray, np.ndarray]:
    """Quadric decimation to at most about ``max_faces`` faces (fast-simplification).

    Args:
        v: Vertices (V, 3), metres. f: faces (F, 3).
        max_faces: Target face count; a mesh with fewer is returned as it is.

    Returns:
        ``(vertices, faces)``.
    """
    if max_faces <= 0 or len(f) <= max_faces:
        return v, f
    import fast_simplification  # heavy, optional at import time

    vs, fs = fast_simplification.simplify(
        np.ascontiguousarray(v, np.float32), np.ascontiguousarray(f, np.int64),
        target_reduction=1.0 - max_faces / len(f),
    )  # fmt: skip
    if len(fs) < 4:
        return v, f  # decimation collapsed it: keep the original
    return np.asarray(vs, np.float64), np.asarray(fs, np.int64)


def _run_coacd(v: np.ndarray, f: np.ndarray, config: DecomposeConfig, closed: bool) -> list:
    from symjax.decompose.worker import run_isolated

    mode = config.preprocess
    if mode == "auto":
        # Whether the mesh given was closed, not its decimation (which can leave a few
        # non-manifold edges): the remeshing took 5x longer than the decomposition.
        mode = "off" if closed else "on"
    return run_isolated(_coacd_parts, v, f, config, mode)


def _coacd_parts(v: np.ndarray, f: np.ndarray, config: DecomposeConfig, mode: str) -> list:
    """coacd itself (runs in the worker process)."""
    import coacd  # heavy, optional at import time

    coacd.set_log_level("error")
    parts = coacd.run_coacd(
        coacd.Mesh(v, f),
        threshold=config.threshold,
        max_convex_hull=config.max_hulls,
        preprocess_resolution=config.preprocess_resolution,
        resolution=config.resolution,
        mcts_iterations=config.mcts_iterations,
        mcts_max_depth=config.mcts_max_depth,
        mcts_nodes=config.mcts_nodes,
        preprocess_mode=mode,
        max_ch_vertex=max(config.max_vertices, 8),
        decimate=True,
        seed=config.seed,
    )
    return [(np.asarray(pv, dtype=np.float64), np.asarray(pf)) for pv, pf in parts]


def _load(path: Path) -> tuple[tuple[np.ndarray, np.ndarray], ...]:
    try:
        with np.load(path) as z:
            n = int(z["n"])
            return tuple((z[f"v{i}"], z[f"f{i}"]) for i in range(n))
    except (OSError, KeyError, ValueError, EOFError, zipfile.BadZipFile) as e:
        raise FileFormatError(f"corrupt coacd cache file {path}: {e}") from e


def _save(path: Path, hulls) -> None:
    buf = io.BytesIO()
    arrays = {"n": np.asarray(len(hulls))}
    for i, (v, f) in enumerate(hulls):
        arrays[f"v{i}"], arrays[f"f{i}"] = v, f
    np.savez(buf, **arrays)
    atomic_write_bytes(path, buf.getvalue())


def decompose(
    mesh: MeshLike,
    config: DecomposeConfig | None = None,
    cache_dir: str | os.PathLike | None = None,
    use_cache: bool = True,
) -> Decomposition:
    """Splits a triangle mesh into capped convex hulls with coacd, cached on disk.

    Args:
        mesh: A ``trimesh.Trimesh`` or ``(vertices (V, 3), faces (F, 3))``, metres.
        config: coacd settings and the vertex cap (default :class:`DecomposeConfig`).
        cache_dir: Cache folder (default :func:`default_cache_dir`). Entries are named by
            :func:`mesh_key`, written atomically; a corrupt entry is recomputed.
        use_cache: Read and write the cache.

    Returns:
        The :class:`Decomposition`.

    Raises:
        DegenerateGeometryError: coacd gave no hull with volume, or crashed on the mesh (it
            runs in a worker process, see :mod:`symjax.decompose.worker`).
    """
    t0 = time.perf_counter()
    config = config if config is not None else DecomposeConfig()
    v, f = mesh_arrays(mesh)
    key = mesh_key((v, f), config)
    path = Path(cache_dir if cache_dir is not None else default_cache_dir()) / f"{key}.npz"
    if use_cache and path.is_file():
        try:
            hulls = _load(path)
            return Decomposition(hulls, key, True, time.perf_counter() - t0)
        except FileFormatError:
            path.unlink(missing_ok=True)
    hulls = []
    closed = is_closed(np.asarray(f, np.int64), len(v))
    for pv, _ in _run_coacd(*simplify(v, f, config.max_faces), config, closed):
        try:
            hulls.append(cap_hull(pv, config.max_vertices))
        except DegenerateGeometryError:
            continue  # a sliver hull adds no volume to collide with
    if not hulls:
        raise DegenerateGeometryError("coacd returned no hull with volume")
    hulls = tuple(hulls)
    if use_cache:
        _save(path, hulls)
    return Decomposition(hulls, key, False, time.perf_counter() - t0)
