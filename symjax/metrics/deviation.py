"""Geometric deviation between two meshes (MeshDev's metric, paper Section V-A.3).

The reference surface is sampled uniformly (by area) and each sample's distance to the closest
point of the other surface is measured exactly (point-to-triangle), so the statistics do not
depend on how either mesh distributes its vertices.
"""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np

from symjax.array_types import ArrayLike, MeshLike
from symjax.errors import EmptyInputError, InvalidInputError, ShapeError
from symjax.geometry import as_trimesh, closest_point_on_triangle

__all__ = ["Deviation", "mesh_deviation", "sample_surface", "surface_distance"]

#: Percentiles reported by :func:`mesh_deviation`.
PERCENTILES = (5, 25, 50, 75, 95, 99)


@dataclasses.dataclass(frozen=True)
class Deviation:
    """Statistics of the distances from reference samples to the other surface, metres.

    Attributes:
        mean: Mean distance.
        variance: Variance of the distances, square metres.
        max: Largest distance.
        percentiles: ``{p: distance}`` for p in :data:`PERCENTILES`.
        n: Number of samples.
    """

    mean: float
    variance: float
    max: float
    percentiles: dict
    n: int


def checked_mesh(mesh: MeshLike, what: str = "mesh"):
    """The mesh input (:func:`symjax.geometry.as_trimesh`), non-empty with finite vertices."""
    mesh = as_trimesh(mesh, what)
    if len(mesh.faces) == 0 or len(mesh.vertices) == 0:
        raise EmptyInputError(f"{what} has no faces")
    # Plain ndarray views: numpy calls on trimesh's TrackedArray wrap every result (a tenth of
    # a 50k-face deviation went there).
    if not np.all(np.isfinite(mesh.vertices.view(np.ndarray))):
        raise InvalidInputError(f"{what} has NaN or inf vertices")
    if not _has_area(mesh):
        raise EmptyInputError(f"{what} has zero surface area")
    return mesh


def _has_area(mesh, chunk: int = 4096) -> bool:
    """Whether any face has a positive area, looked for a chunk of faces at a time: the full
    area of a 50k-face mesh costs a tenth of its deviation, and the first chunk decides."""
    v = mesh.vertices.view(np.ndarray).astype(np.float64, copy=False)
    f = mesh.faces.view(np.ndarray)
    for s in range(0, len(f), chunk):
        a, b, c = (v[f[s : s + chunk, k]] for k in range(3))
        if np.any(np.linalg.norm(np.cross(b - a, c - a), axis=1) > 0):
            return True
    return False


def sample_surface(mesh: MeshLike, n: int, seed: int = 0) -> np.ndarray:
    """Uniform samples of a mesh surface: faces by area, points uniform in each face.

    Args:
        mesh: A ``trimesh.Trimesh``.
        n: Number of samples.
        seed: Random seed; the same seed on meshes with the same faces gives the same
            barycentric samples.

    Returns:
        (n, 3) points on the surface, metres.
    """
    mesh = checked_mesh(mesh)
    if int(n) < 1:
        raise InvalidInputError(f"n_samples must be >= 1, got {n}")
    rng = np.random.default_rng(seed)
    tri = np.asarray(mesh.triangles, dtype=np.float64)
    cum = np.cumsum(np.asarray(mesh.area_faces, dtype=np.float64))
    face = np.searchsorted(cum, rng.random(int(n)) * cum[-1], side="right")
    face = np.minimum(face, len(cum) - 1)
    r1 = np.sqrt(rng.random(int(n)))
    r2 = rng.random(int(n))
    a, b, c = tri[face, 0], tri[face, 1], tri[face, 2]
    return (1 - r1)[:, None] * a + (r1 * (1 - r2))[:, None] * b + (r1 * r2)[:, None] * c


def surface_distance(
    points: ArrayLike,
    mesh: MeshLike,
    *,
    candidates: int | None = None,
    return_faces: bool = False,
    chunk: int = 4096,
) -> np.ndarray | tuple[np.ndarray, np.ndarray]:
    """Distance of each point to the closest point of a mesh surface.

    Exact by default: a bounding-volume hierarchy of the triangles (FCPW's, where it has a
    wheel; libigl's AABB tree elsewhere) finds each point's closest face, and the distance to
    that face is taken in float64. A hierarchy does not care how unevenly the triangles are
    sized, where the k-d tree of face centroids it replaced had to widen every query by the
    largest triangle.
    ``candidates=k`` compares each point with its ``k`` nearest face centroids only: an upper
    bound of the distance, tight for the small triangles of scans and several times faster
    (the benchmark's preprocessing and renderer use it; its checks are conservative).

    Args:
        points: (N, 3) query points, metres.
        mesh: A ``trimesh.Trimesh`` or ``(vertices (V, 3), faces (F, 3))``.
        candidates: None for the exact distance, else faces compared per point.
        return_faces: Also return the closest face of each point.
        chunk: Points processed at once by the exact query (bounds memory).

    Returns:
        (N,) distances, metres; with ``return_faces``, ``(distances, faces (N,) int64)``.
    """

    mesh = checked_mesh(mesh)
    p = np.asarray(points, dtype=np.float64)
    if p.ndim != 2 or p.shape[1] != 3:
        raise ShapeError(f"points must have shape (N, 3), got {p.shape}")
    if len(p) == 0:
        empty = np.zeros(0)
        return (empty, np.zeros(0, np.int64)) if return_faces else empty
    if candidates is not None:
        tri = np.asarray(mesh.triangles, dtype=np.float64)
        tree = _face_tree(mesh, tri.mean(axis=1))
        k = min(int(candidates), len(tri))
        _, cand = tree.query(p, k=k)
        cand = np.asarray(cand).reshape(len(p), k)
        # trimesh's routine, as the benchmark was rendered with: ties on shared edges then break
        # the same way, and so do the normals taken from the closest face.
        import trimesh

        cp = trimesh.triangles.closest_point(tri[cand.ravel()], np.repeat(p, k, axis=0))
        d = np.linalg.norm(cp - np.repeat(p, k, axis=0), axis=1).reshape(len(p), k)
        best = np.argmin(d, axis=1)
        rows = np.arange(len(p))
        return (d[rows, best], cand[rows, best]) if return_faces else d[rows, best]
    bvh = _bvh(mesh)
    face = np.empty(p.shape[0], np.int64)
    for s in range(0, p.shape[0], chunk):
        face[s : s + chunk] = bvh.closest_faces(p[s : s + chunk])
    out = _face_distance(p, bvh.v[bvh.f[face]])
    return (out, face) if return_faces else out


def _face_distance(p: np.ndarray, tri: np.ndarray) -> np.ndarray:
    """Float64 distance of each point (N, 3) to its triangle (N, 3, 3), metres: the trees
    only choose the face (FCPW works in float32)."""
    return np.linalg.norm(closest_point_on_triangle(p, tri) - p, axis=1)


class _FcpwTree:
    """FCPW's BVH (longest-axis splits, SIMD queries): for 50k faces a tenth of libigl's
    build time, which dominated a deviation. Float32, so the mesh is moved to its vertex mean
    first; the closest face it returns is within float32 rounding (1e-8 m at object scale)
    of libigl's, and the distance is recomputed in float64 on that face."""

    def __init__(self, v: np.ndarray, f: np.ndarray):
        import fcpw

        self.v, self.f = v, f
        self.origin = v.mean(axis=0)
        self.scene = fcpw.scene_3D()
        self.scene.set_object_count(1)
        self.scene.set_object_vertices(np.asfortranarray(v - self.origin, np.float32), 0)
        self.scene.set_object_triangles(np.asfortranarray(f, np.int32), 0)
        self.scene.build(fcpw.aggregate_type.bvh_longest_axis_center, True)

    def closest_faces(self, p: np.ndarray) -> np.ndarray:
        import fcpw

        hits = fcpw.interaction_3D_list()
        q = np.asfortranarray(p - self.origin, np.float32)
        self.scene.find_closest_points(q, np.full(len(q), np.inf, np.float32), hits)
        return np.fromiter((h.primitive_index for h in hits), np.int64, len(q))


class _IglTree:
    """libigl's AABB tree (float64), where FCPW has no wheel."""

    def __init__(self, v: np.ndarray, f: np.ndarray):
        import igl

        self.v, self.f = v, f
        self.tree = igl.AABB()
        self.tree.init(v, f)

    def closest_faces(self, p: np.ndarray) -> np.ndarray:
        return np.asarray(self.tree.squared_distance(self.v, self.f, np.ascontiguousarray(p))[1])


def _tree_kind() -> type:
    try:
        import fcpw  # noqa: F401
    except ImportError:
        return _IglTree
    return _FcpwTree


def _bvh(mesh: Any):
    """The mesh's closest-face tree, kept on the mesh with the arrays it was built from
    (rebuilt if they changed)."""
    got = mesh.__dict__.get("_symjax_bvh")
    if (got is not None and np.array_equal(got.v, mesh.vertices)
            and np.array_equal(got.f, mesh.faces)):  # fmt: skip
        return got
    # Copies: the mesh's own arrays may be changed in place afterwards.
    v = np.array(mesh.vertices, np.float64, order="C", copy=True)
    f = np.array(mesh.faces, np.int64, order="C", copy=True)
    mesh.__dict__["_symjax_bvh"] = _tree_kind()(v, f)
    return mesh.__dict__["_symjax_bvh"]


def _face_tree(mesh: Any, centroids: np.ndarray):
    """The k-d tree of a mesh's face centroids, kept on the mesh with the centroids it holds."""
    from scipy.spatial import cKDTree

    got = mesh.__dict__.get("_symjax_face_tree")
    if got is None or not np.array_equal(got[1], centroids):  # also when moved in place
        got = (cKDTree(centroids), np.array(centroids, copy=True))
        mesh.__dict__["_symjax_face_tree"] = got
    return got[0]


def mesh_deviation(
    reference: MeshLike, mesh: MeshLike, n_samples: int = 20000, seed: int = 0
) -> Deviation:
    """Geometric deviation of ``mesh`` from ``reference`` (MeshDev, paper Section V-A.3).

    Args:
        reference: Ground-truth ``trimesh.Trimesh``; its surface is sampled uniformly.
        mesh: The ``trimesh.Trimesh`` to evaluate.
        n_samples: Number of uniform samples of the reference surface.
        seed: Sampling seed (see :func:`sample_surface`).

    Returns:
        :class:`Deviation` of the distances (metres) from the samples to ``mesh``.
    """
    reference = checked_mesh(reference, "reference")
    mesh = checked_mesh(mesh)
    d = surface_distance(sample_surface(reference, n_samples, seed), mesh)
    return Deviation(
        mean=float(d.mean()),
        variance=float(d.var()),
        max=float(d.max()),
        percentiles=dict(zip(PERCENTILES, map(float, np.percentile(d, PERCENTILES)), strict=True)),
        n=int(d.size),
    )
