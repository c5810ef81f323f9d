"""Deterministic preprocessing of a raw scan into the *canonical object frame*.

* parts: slivers are dropped; a connected component is kept when it holds at least
  ``min_part_area`` of the surface (the main component, plus separate parts such as the
  Windex spray head, which the scan stores as its own closed shell);
* holes are filled where the scan is (nearly) closed, so that the mesh is watertight when possible;
* the lowest point rests on the table (z = 0), the area centroid of the surface projects to the
  origin and the principal axis of the table-projected convex hull (its longest dimension) is +x.
  Orientation 0 deg of the benchmark therefore means "object x axis parallel to the image plane".
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from symjax.array_types import MeshLike
from symjax.errors import (
    DegenerateGeometryError,
)
from symjax.geometry import rot_z
from symjax.validation import check_fields

__all__ = ["PreprocessConfig", "area_centroid", "preprocess_mesh", "table_principal_axis"]


@dataclass(frozen=True)
class PreprocessConfig:
    """Mesh preprocessing settings.

    Attributes:
        min_part_area: A connected component is kept when its area is at least this fraction of
            the total surface area (drops scanning slivers, keeps real separate parts).
        max_hole_fill: Holes are filled only when the mesh's open boundary has at most this many
            edges (a "nearly closed" scan); larger openings are left open.
        merge_tol: Vertices closer than this are merged before hole filling, metres.
    """

    min_part_area: float = 0.05
    max_hole_fill: int = 200
    merge_tol: float = 1e-6

    def __post_init__(self) -> None:
        check_fields(self)


def area_centroid(mesh: MeshLike) -> np.ndarray:
    a = np.asarray(mesh.area_faces, np.float64)
    return (np.asarray(mesh.triangles_center) * a[:, None]).sum(0) / a.sum()


def table_principal_axis(mesh: MeshLike) -> np.ndarray:
    """Principal axis (longest dimension) of the mesh's table-projected convex hull.

    The axis of largest second moment of area of the hull polygon in the xy plane; its sign is
    fixed so that the hull reaches further along +axis than along -axis (deterministic).

    Returns:
        Unit vector (3,) with zero z.

    Raises:
        DegenerateGeometryError: If the projection has no area.
    """
    from scipy.spatial import ConvexHull

    xy = np.asarray(mesh.vertices, np.float64)[:, :2]
    try:
        hull = ConvexHull(xy)
    except Exception as e:  # scipy raises QhullError on collinear input
        raise DegenerateGeometryError(f"table projection of the mesh has no area: {e}") from e
    poly = xy[hull.vertices]  # counter-clockwise
    p0, p1 = poly, np.roll(poly, -1, axis=0)
    cross = p0[:, 0] * p1[:, 1] - p1[:, 0] * p0[:, 1]
    area = cross.sum() / 2
    c = ((p0 + p1) * cross[:, None]).sum(0) / (6 * area)
    q0, q1 = p0 - c, p1 - c
    cr = q0[:, 0] * q1[:, 1] - q1[:, 0] * q0[:, 1]
    ixx = (cr * (q0[:, 0] ** 2 + q0[:, 0] * q1[:, 0] + q1[:, 0] ** 2)).sum() / 12
    iyy = (cr * (q0[:, 1] ** 2 + q0[:, 1] * q1[:, 1] + q1[:, 1] ** 2)).sum() / 12
    ixy = (
        cr * (q0[:, 0] * q1[:, 1] + 2 * q0[:, 0] * q0[:, 1] + 2 * q1[:, 0] * q1[:, 1])
        + cr * (q1[:, 0] * q0[:, 1])
    ).sum() / 24
    w, v = np.linalg.eigh(np.array([[ixx, ixy], [ixy, iyy]]))
    axis = v[:, int(np.argmax(w))]
    proj = (poly - c) @ axis
    if proj.max() < -proj.min():
        axis = -axis
    return np.array([axis[0], axis[1], 0.0])


def preprocess_mesh(
    mesh: MeshLike, lying: bool = False, config: PreprocessConfig = PreprocessConfig()
) -> Any:
    """Cleans a raw scan and moves it into the canonical object frame (module docstring).

    Args:
        mesh: Raw ``trimesh.Trimesh`` in metres, z up.
        lying: Lay the object on its side first: a +90 deg turn about its table-projected
            principal axis, so that its thinnest horizontal dimension becomes vertical.
        config: Preprocessing settings.

    Returns:
        A new canonical ``trimesh.Trimesh``.

    Raises:
        DegenerateGeometryError: If the mesh has no area or is not finite.
    """
    import trimesh

    m = trimesh.Trimesh(
        np.asarray(mesh.vertices, np.float64), np.asarray(mesh.faces, np.int64), process=False
    )
    if not np.all(np.isfinite(m.vertices)) or m.area <= 0:
        raise DegenerateGeometryError("mesh has no area or non-finite vertices")
    m.merge_vertices(digits_vertex=max(0, int(round(-math.log10(config.merge_tol)))))
    m.update_faces(m.nondegenerate_faces())
    m.remove_unreferenced_vertices()
    parts = m.split(only_watertight=False)
    if len(parts) > 1:
        total = sum(p.area for p in parts)
        keep = [p for p in parts if p.area >= config.min_part_area * total]
        # Stable order (by first vertex position) keeps the preprocessing deterministic.
        keep.sort(key=lambda p: (-p.area, tuple(np.round(p.bounds[0], 9))))
        m = trimesh.util.concatenate(keep)
    if not m.is_watertight:
        n_open = len(trimesh.grouping.group_rows(m.edges_sorted, require_count=1))
        if n_open <= config.max_hole_fill:
            trimesh.repair.fill_holes(m)
    trimesh.repair.fix_normals(m)
    if lying:
        m.apply_translation(-area_centroid(m))
        axis = table_principal_axis(m)
        m.apply_transform(trimesh.transformations.rotation_matrix(math.pi / 2, axis))
    # Canonical frame: area centroid at the origin in xy, principal hull axis along +x, z = 0 at
    # the lowest point.
    c = area_centroid(m)
    m.apply_translation([-c[0], -c[1], 0.0])
    axis = table_principal_axis(m)
    T = np.eye(4)
    T[:3, :3] = rot_z(-math.atan2(axis[1], axis[0]))
    m.apply_transform(T)
    c = area_centroid(m)
    m.apply_translation([-c[0], -c[1], -m.bounds[0, 2]])
    return m


# ----------------------------------------------------------------------------------------------
