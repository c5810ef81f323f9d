"""The paper's baseline mesh without mirroring (Section V-A.2).

"We applied a Delaunay triangulation to the projection of a uniformly sampled subset of 500
points from the original point cloud. Spurious edges are filtered based on their length in 2D and
3D. Furthermore, we extract the outer contour edges of this triangulation and span triangles
between them which produces a watertight mesh."

symjax reads this as: triangulate the image projection of the subset, drop triangles with an edge
longer than a 2-D (pixels) or 3-D (metres) threshold, keep the largest connected piece, and close
the resulting front sheet by a back copy of it pushed along the viewing rays to the depth of the
farthest sample, with the contour edges of the sheet spanned to their back copies by a strip of
triangles. Contours of holes inside the sheet are spanned the same way, so the result is always
watertight.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from symjax.array_types import ArrayLike
from symjax.errors import DegenerateGeometryError, InvalidInputError
from symjax.surface.config import DelaunayConfig
from symjax.surface.normals import _as_points, check_not_degenerate

__all__ = ["delaunay_mesh"]


def _edges(faces: np.ndarray) -> np.ndarray:
    """Directed edges (3F, 2) of faces (F, 3), face by face: (a,b), (b,c), (c,a)."""
    return np.stack([faces, np.roll(faces, -1, axis=1)], axis=-1).reshape(-1, 2)


def _largest_piece(faces: np.ndarray, n_vertices: int) -> np.ndarray:
    """Faces of the largest edge-connected piece (faces sharing an edge are connected)."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    e = np.sort(_edges(faces), axis=1)
    key = e[:, 0] * n_vertices + e[:, 1]
    face_of = np.repeat(np.arange(faces.shape[0]), 3)
    order = np.argsort(key, kind="stable")
    ks, fs = key[order], face_of[order]
    same = ks[1:] == ks[:-1]
    a, b = fs[:-1][same], fs[1:][same]
    nf = faces.shape[0]
    g = coo_matrix((np.ones(a.size, np.int8), (a, b)), shape=(nf, nf))
    _, labels = connected_components(g, directed=False)
    return faces[labels == np.argmax(np.bincount(labels))]


def _without_pinches(faces: np.ndarray, n_vertices: int, max_rounds: int = 20) -> np.ndarray:
    """Drops faces around pinch vertices (two contour loops through one vertex).

    The strip spanned from a pinch vertex to its back copy would be shared by four triangles;
    without pinches every contour vertex has exactly one outgoing contour edge.
    """
    for _ in range(max_rounds):
        e = _edges(faces)
        key = np.sort(e, axis=1)
        k = key[:, 0] * n_vertices + key[:, 1]
        _, inv, counts = np.unique(k, return_inverse=True, return_counts=True)
        starts = np.bincount(e[counts[inv] == 1, 0], minlength=n_vertices)
        pinch = starts > 1
        if not pinch.any():
            return faces
        faces = faces[~np.any(pinch[faces], axis=1)]
        if faces.shape[0] == 0:
            break
        faces = _largest_piece(faces, n_vertices)
    raise DegenerateGeometryError("could not build a manifold sheet from the triangulation")


def delaunay_mesh(points: ArrayLike, camera: Any, config: DelaunayConfig | None = None):
    """Watertight baseline mesh of an observed (not mirrored) cloud, paper Section V-A.2.

    Args:
        points: (N, 3) observed world points, metres (e.g. ``Observation.valid_points()``).
        camera: The :class:`~symjax.camera.Camera` that saw them.
        config: Baseline configuration (500 samples by default, as in the paper).

    Returns:
        A watertight, outward-oriented ``trimesh.Trimesh`` in world coordinates, metres.

    Raises:
        EmptyInputError: With fewer than ``config.min_points`` points.
        DegenerateGeometryError: If the points or their projection are collinear, or the edge
            filter leaves no triangle.
    """
    import trimesh
    from scipy.spatial import Delaunay, QhullError

    config = config or DelaunayConfig()
    if not isinstance(config, DelaunayConfig):
        raise InvalidInputError(f"config must be a DelaunayConfig, got {type(config).__name__}")
    p = _as_points(points)
    check_not_degenerate(p, config.min_points, allow_planar=True)
    if p.shape[0] > config.n_samples:
        rng = np.random.default_rng(config.seed)
        p = p[np.sort(rng.choice(p.shape[0], config.n_samples, replace=False))]
    uv, z = camera.project(p)
    uv, z = np.asarray(uv, np.float64), np.asarray(z, np.float64)
    if np.any(z <= 0):
        raise InvalidInputError(f"{int(np.sum(z <= 0))} points are behind the camera")
    try:
        faces = Delaunay(uv).simplices.astype(np.int64)
    except QhullError as err:
        raise DegenerateGeometryError(
            f"the image projection of the {p.shape[0]} points is degenerate (collinear)"
        ) from err

    e = _edges(faces)
    len2 = np.linalg.norm(uv[e[:, 0]] - uv[e[:, 1]], axis=1).reshape(-1, 3)
    len3 = np.linalg.norm(p[e[:, 0]] - p[e[:, 1]], axis=1).reshape(-1, 3)
    max2 = config.max_edge_px or config.edge_factor * float(np.median(len2))
    max3 = config.max_edge_m or config.edge_factor * float(np.median(len3))
    faces = faces[np.all((len2 <= max2) & (len3 <= max3), axis=1)]
    if faces.shape[0] == 0:
        raise DegenerateGeometryError(
            f"no triangle has all edges below {max2:.3g} px and {max3:.3g} m; raise the limits"
        )
    faces = _largest_piece(faces, p.shape[0])
    faces = _without_pinches(faces, p.shape[0])

    # Orient the sheet towards the camera: counter-clockwise in the image is one 3-D side.
    d1, d2 = uv[faces[:, 1]] - uv[faces[:, 0]], uv[faces[:, 2]] - uv[faces[:, 0]]
    ccw = d1[:, 0] * d2[:, 1] - d1[:, 1] * d2[:, 0] > 0
    faces = np.where(ccw[:, None], faces, faces[:, ::-1])
    used = np.unique(faces)
    remap = np.full(p.shape[0], -1, np.int64)
    remap[used] = np.arange(used.size)
    front, z, faces = p[used], z[used], remap[faces]
    n = front.shape[0]

    cam = np.asarray(camera.position, np.float64)
    z_back = np.maximum(z.max(), z + config.thickness)
    back = cam + (front - cam) * (z_back / z)[:, None]

    # Contour edges are used by one face only; keep their direction as in that face.
    e = _edges(faces)
    key = np.sort(e, axis=1)
    _, inv, counts = np.unique(key[:, 0] * n + key[:, 1], return_inverse=True, return_counts=True)
    a, b = e[counts[inv] == 1].T
    side = np.concatenate([np.stack([b, a, a + n], 1), np.stack([b, a + n, b + n], 1)])
    all_faces = np.concatenate([faces, faces[:, ::-1] + n, side])
    mesh = trimesh.Trimesh(np.concatenate([front, back]), all_faces, process=False)
    if mesh.volume < 0:
        mesh.invert()
    if not mesh.is_watertight:
        raise DegenerateGeometryError("the baseline mesh is not watertight (non-manifold sheet)")
    return mesh
