"""Meshes to and from files (PLY, OBJ, STL) through trimesh, written atomically."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from symjax._atomic import atomic_write_bytes
from symjax.array_types import ArrayLike, MeshLike
from symjax.errors import InvalidInputError, ShapeError
from symjax.io._common import existing_file, format_error

__all__ = ["MESH_FORMATS", "read_mesh", "write_mesh"]

#: Mesh suffixes :func:`write_mesh` and :func:`read_mesh` know.
MESH_FORMATS = (".ply", ".obj", ".stl")


def _suffix(path: Path) -> str:
    s = path.suffix.lower()
    if s not in MESH_FORMATS:
        raise format_error(path, f"unknown mesh format {s!r}; expected one of {MESH_FORMATS}")
    return s


def write_mesh(path: str | os.PathLike, mesh: MeshLike, faces: ArrayLike = None) -> Path:
    """Writes a triangle mesh; the format (PLY binary, OBJ, STL binary) follows the suffix.

    Args:
        path: Output file.
        mesh: A ``trimesh.Trimesh``, or vertices (V, 3) in metres when ``faces`` is given.
        faces: Triangles (F, 3) of vertex indices, when ``mesh`` is a vertex array.

    Raises:
        ShapeError: Vertices or faces of the wrong shape.
        InvalidInputError: Face indices out of range, or an empty mesh.
        FileFormatError: Unknown suffix.
    """
    import trimesh

    p = Path(path)
    suffix = _suffix(p)
    if faces is not None or not isinstance(mesh, trimesh.Trimesh):
        v = np.asarray(mesh, dtype=np.float64)
        f = np.asarray(faces if faces is not None else np.zeros((0, 3)), dtype=np.int64)
        if v.ndim != 2 or v.shape[1] != 3:
            raise ShapeError(f"mesh vertices must have shape (V, 3), got {v.shape}")
        if f.ndim != 2 or f.shape[1] != 3:
            raise ShapeError(f"mesh faces must have shape (F, 3), got {f.shape}")
        if f.size and (f.min() < 0 or f.max() >= len(v)):
            raise InvalidInputError(
                f"face indices must be in [0, {len(v)}), got {f.min()}..{f.max()}"
            )
        mesh = trimesh.Trimesh(vertices=v, faces=f, process=False)
    if len(mesh.faces) == 0:
        raise InvalidInputError("mesh has no faces; write a point cloud instead")
    data = mesh.export(file_type=suffix[1:])
    return atomic_write_bytes(p, data.encode("utf-8") if isinstance(data, str) else data)


def read_mesh(path: str | os.PathLike):
    """Reads a triangle mesh (``trimesh.Trimesh``, unprocessed) from PLY, OBJ or STL.

    Raises:
        MissingFileError: If the file does not exist.
        FileFormatError: Unknown suffix, corrupt file, or no triangles.
    """
    import trimesh

    p = existing_file(path, "mesh")
    suffix = _suffix(p)
    try:
        mesh = trimesh.load(str(p), file_type=suffix[1:], process=False, force="mesh")
    except Exception as e:  # trimesh raises many types on corrupt input
        raise format_error(p, f"cannot parse the mesh ({type(e).__name__}: {e})") from None
    if not isinstance(mesh, trimesh.Trimesh) or len(mesh.faces) == 0:
        raise format_error(p, "holds no triangles")
    return mesh
