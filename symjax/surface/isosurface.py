"""Marching cubes of a solved Poisson grid into a closed, outward-oriented mesh.

scikit-image's marching cubes runs on the host, the grid surrounded by one layer of "outside"
so that the surface is always closed; the largest connected component is kept.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from symjax.errors import (
    DegenerateGeometryError,
    ShapeError,
)
from symjax.geometry import is_closed
from symjax.surface.config import PoissonConfig
from symjax.surface.poisson_grid import PoissonGrid

__all__ = ["InsideOutError", "evidence_hull", "grid_to_mesh"]

#: Facets of the evidence hull closer to coplanar than this are merged (qhull's centrum
#: option), metres: a noisy face of 20,000 points is one facet instead of hundreds, and the
#: clip costs 20-30 ms a depth-7 grid instead of 200 ms.
HULL_MERGE = 0.001


class InsideOutError(DegenerateGeometryError):
    """The indicator is larger far from the points than on them: normals into the object, or
    an open sheet seen from its concave side (a bowl from above)."""


def _large_components(verts: np.ndarray, faces: np.ndarray, share: float):
    """The connected components with at least ``share`` of the largest one's faces."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    nv = verts.shape[0]
    e = np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]]], axis=0)
    graph = coo_matrix((np.ones(len(e), np.int8), (e[:, 0], e[:, 1])), shape=(nv, nv))
    n_comp, labels = connected_components(graph, directed=False)
    if n_comp == 1:
        return verts, faces
    face_label = labels[faces[:, 0]]
    size = np.bincount(face_label, minlength=n_comp)
    kept = size >= share * size.max()
    if share >= 1.0:  # the largest alone, even against a twin of its size
        kept = np.arange(n_comp) == np.argmax(size)
    faces = faces[kept[face_label]]
    keep = np.zeros(nv, bool)
    keep[faces] = True
    used = np.flatnonzero(keep)
    remap = np.full(nv, -1, np.int64)
    remap[used] = np.arange(used.size)
    return verts[used], remap[faces]


def _signed_volume(verts: np.ndarray, faces: np.ndarray) -> float:
    """Enclosed volume of a closed mesh, positive when its faces wind outwards, m^3."""
    a, b, c = verts[faces[:, 0]], verts[faces[:, 1]], verts[faces[:, 2]]
    return float(np.einsum("ij,ij->", a, np.cross(b, c)) / 6.0)


def _clip_below(chi: np.ndarray, grid: PoissonGrid, table: Any, iso: float, span: float):
    """``min(chi, iso + s h)``, h the height above the table: the intersection with the half
    space above it. The slope ``s`` is one ``span`` per cell, so the term is outside one cell
    below the plane and has no effect one cell above; being linear in h, marching cubes puts
    its crossing exactly on the plane."""
    n = np.asarray(table.normal, np.float64)
    n = n / np.linalg.norm(n)
    cell = float(grid.cell)
    axes = [np.arange(m) * cell for m in chi.shape]
    origin = np.asarray(grid.origin, np.float64)
    # In float64, summed axis by axis in this order: grid nodes on the plane sit exactly at the
    # iso-value, so the rounding decides their side. One full-size temporary, scaled in place.
    h = (float(n @ origin + table.offset) + n[0] * axes[0])[:, None] + n[1] * axes[1][None, :]
    h = h[:, :, None] + n[2] * axes[2][None, None, :]
    h *= span / cell
    h += iso
    return np.minimum(chi, h.astype(chi.dtype))


def evidence_hull(points: np.ndarray, table: Any = None) -> np.ndarray | None:
    """Facets (F, 4) ``[n, d]``, ``n . x + d <= 0`` inside, of the convex hull of the points
    and, with a table, of their footprint on it; None for a flat or degenerate cloud.

    A completion claims no space that nothing in the evidence spans: on the benchmark, Poisson
    surfaces of completed clouds balloon beyond their points where the sides of an object were
    never seen (a box seen edge-on: 23 mm mean deviation), and the hull cuts that away.
    """
    from scipy.spatial import ConvexHull, QhullError

    p = np.asarray(points, np.float64)
    try:
        # The hull's corners carry it: the footprint of the corners spans that of all points
        # (a projection maps hulls onto hulls), and the merged hull is found among them.
        p = p[ConvexHull(p).vertices]
        if table is not None:
            n = np.asarray(table.normal, np.float64)
            p = np.concatenate([p, p - np.asarray(table.height(p), np.float64)[:, None] * n])
        eq = ConvexHull(p, qhull_options=f"C-{HULL_MERGE}").equations
    except (QhullError, ValueError):
        return None
    # A merged facet's plane can pass up to the merge tolerance inside some of its points:
    # each facet is moved out to the farthest point along its normal (the support function),
    # so the polytope holds every point (a sampled sphere otherwise lost 5 % of its volume).
    eq[:, 3] = -(p @ eq[:, :3].T).max(axis=0)
    return eq


def _clip_outside(chi: np.ndarray, grid: PoissonGrid, hull: np.ndarray, iso: float, span: float):
    """``min(chi, iso - s e)``, ``e`` the largest facet distance of a node outside ``hull``
    (:func:`evidence_hull`), slope one ``span`` per cell as in :func:`_clip_below`: the
    intersection with the hull.

    ``e`` moves by at most the distance moved (unit normals), so it is evaluated exactly on
    every other node of the box that holds the surface and, from there, only on the nodes near
    the hull's boundary; nodes well inside keep their value and nodes well outside are set
    outside (a depth-7 grid: 1 M nodes inside the surface, 160 -> ~40 ms).
    """
    box = _crossing_box(chi, iso)
    sub = chi[box]
    cell = float(grid.cell)
    a, d = hull[:, :3], hull[:, 3]
    start = np.asarray(grid.origin, np.float64) + cell * np.array([b.start for b in box])

    a32, d32 = a.astype(np.float32), d.astype(np.float32)

    def excess(ijk: np.ndarray) -> np.ndarray:
        x, y, z = (start + cell * ijk).astype(np.float32).T.copy()
        out = np.full(len(x), -np.inf, np.float32)
        tmp = np.empty_like(out)
        # A facet at a time over (N,) vectors, not ``x @ a.T``: a matmul of inner size 3 gains
        # nothing from BLAS, whose threads then spin against the other views' meshing (a
        # depth-7 batch on 2 cores: 126 -> 83 ms a view), and no (N, F) temporary is made.
        for (ax, ay, az), dk in zip(a32, d32, strict=True):
            np.multiply(x, ax, out=tmp)
            tmp += y * ay
            tmp += z * az
            tmp += dk
            np.maximum(out, tmp, out=out)
        return out

    coarse = [np.arange(0, m, 2) for m in sub.shape]
    mesh = np.stack(np.meshgrid(*coarse, indexing="ij"), axis=-1).reshape(-1, 3)
    e = excess(mesh.astype(np.float64)).reshape([len(c) for c in coarse])
    for axis, m in enumerate(sub.shape):  # each node takes its coarse neighbour's value
        e = np.repeat(e, 2, axis=axis).take(np.arange(m), axis=axis)
    reach = np.sqrt(3.0) * cell + cell  # the neighbour is at most sqrt(3) cells away
    near = (np.abs(e) <= reach) & (sub >= iso)
    idx = np.nonzero(near)
    exact = excess(np.stack(idx, axis=1).astype(np.float64))
    clipped = np.where(e > reach, np.float32(iso - span), sub)  # well outside the hull
    clipped[idx] = np.minimum(sub[idx], np.float32(iso) - np.float32(span) * exact / cell)
    chi[box] = clipped
    return chi


def _crossing_box(chi: np.ndarray, iso: float) -> tuple[slice, slice, slice]:
    """The sub-grid holding every cell where chi reaches ``iso``, one cell of margin: marching
    cubes finds no crossing outside it, and scans a third of the grid instead of all of it."""
    inside = chi >= iso
    box = []
    for axis in range(3):
        hit = np.flatnonzero(inside.any(axis=tuple(a for a in range(3) if a != axis)))
        box.append(slice(max(int(hit[0]) - 1, 0), min(int(hit[-1]) + 2, chi.shape[axis])))
    return tuple(box)


def grid_to_mesh(grid: PoissonGrid, config: PoissonConfig, table: Any = None, hull=None):
    """Marching cubes of one solved grid into a closed, outward-oriented mesh.

    Args:
        grid: A single-view :class:`PoissonGrid`.
        config: Configuration (``min_component``).
        table: A :class:`~symjax.table.TablePlane` the object stands on, or None. The surface
            is cut there and closed by the plane: the indicator is intersected with the half
            space above the table, so the mesh stays closed and its bottom is flat.
        hull: Facets (F, 4) of :func:`evidence_hull`, or None: the indicator is intersected
            with the hull as it is with the table.

    Returns:
        A watertight ``trimesh.Trimesh`` in world coordinates, metres.

    Raises:
        DegenerateGeometryError: If the iso-surface is empty or not watertight.
    """
    import trimesh
    from skimage import measure

    chi = np.asarray(grid.chi, dtype=np.float32)
    if chi.ndim != 3:
        raise ShapeError("grid_to_mesh() needs one view; index the batch first: grid[i]")
    iso = float(grid.iso)
    if not np.isfinite(iso) or not np.all(np.isfinite(chi)):
        raise DegenerateGeometryError("the Poisson solve produced NaN; check points and normals")
    lo_v, hi_v = float(chi.min()), float(chi.max())
    if not (lo_v < iso < hi_v):
        raise DegenerateGeometryError(
            "the indicator function does not cross its iso-value: no surface to extract"
        )
    border = np.concatenate(
        [chi[[0, -1]].ravel(), chi[:, [0, -1]].ravel(), chi[:, :, [0, -1]].ravel()]
    )
    if np.median(border) >= iso:
        # Far from the points chi must be "outside"; otherwise the normals point inwards.
        raise InsideOutError(
            "the indicator function is inside-out (larger than the iso-value far from the points):"
            " the normals point into the object; expected outward-facing normals"
        )
    if table is not None:
        chi = _clip_below(chi, grid, table, iso, hi_v - lo_v)
    if hull is not None:
        chi = _clip_outside(np.array(chi), grid, hull, iso, hi_v - lo_v)
        if not float(chi.max()) > iso:
            raise DegenerateGeometryError("nothing of the surface lies inside the points' hull")
    # One layer of "outside" around the grid closes surfaces that reach the box faces.
    box = _crossing_box(chi, iso)
    vol = np.pad(chi[box], 1, mode="constant", constant_values=min(lo_v, iso - 1.0))
    verts, faces, _, _ = measure.marching_cubes(vol, level=iso)
    start = np.array([b.start for b in box], np.float64)
    verts = np.asarray(grid.origin, np.float64) + (verts - 1.0 + start) * float(grid.cell)
    faces = faces.astype(np.int64)
    if config.min_component > 0:
        verts, faces = _large_components(verts, faces, config.min_component)
    if _signed_volume(verts, faces) < 0:
        faces = faces[:, ::-1]
    if not is_closed(faces, verts.shape[0]):
        raise DegenerateGeometryError(
            "marching cubes returned a mesh that is not watertight; try another depth"
        )
    mesh = trimesh.Trimesh(verts, faces, process=False)
    return mesh
