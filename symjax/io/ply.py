"""PLY point clouds, read by trimesh and written ASCII or binary."""

from __future__ import annotations

import io as _io
from pathlib import Path

import numpy as np

from symjax.io._common import format_error
from symjax.io.cloud_data import PointCloud, finish

__all__ = ["ply_bytes", "read_ply"]


def read_ply(path: Path, scale: float) -> PointCloud:
    import trimesh

    try:
        geom = trimesh.load(str(path), file_type="ply", process=False)
    except Exception as e:  # trimesh raises many types on corrupt input
        raise format_error(path, f"cannot parse the PLY ({type(e).__name__}: {e})") from None
    verts = getattr(geom, "vertices", None)
    if verts is None:
        raise format_error(path, f"PLY holds no vertices (got a {type(geom).__name__})")
    colors = None
    vc = getattr(getattr(geom, "visual", None), "vertex_colors", None)
    if isinstance(geom, trimesh.PointCloud):
        vc = geom.colors if len(geom.colors) else None
    if vc is not None and len(vc) == len(verts):
        colors = np.asarray(vc)[:, :3]
    normals = None
    attrs = getattr(geom, "metadata", {}).get("_ply_raw", {}).get("vertex", {}).get("data")
    # Binary PLY data comes as a record array, ASCII as a dict of columns.
    names = attrs.dtype.names if isinstance(attrs, np.ndarray) else attrs
    if attrs is not None and names and all(k in names for k in ("nx", "ny", "nz")):
        normals = np.stack([np.ravel(attrs[k]) for k in ("nx", "ny", "nz")], axis=1)
    return finish(path, verts, colors, normals, None, scale)


# PCD TYPE letter and SIZE in bytes -> numpy dtype code.
def ply_bytes(pts, colors, normals, binary: bool) -> bytes:
    names = [("x", "f4"), ("y", "f4"), ("z", "f4")]
    if normals is not None:
        names += [("nx", "f4"), ("ny", "f4"), ("nz", "f4")]
    if colors is not None:
        names += [("red", "u1"), ("green", "u1"), ("blue", "u1")]
    rec = np.empty(len(pts), dtype=[(k, "<" + t) for k, t in names])
    for i, k in enumerate("xyz"):
        rec[k] = pts[:, i]
    if normals is not None:
        for i, k in enumerate(("nx", "ny", "nz")):
            rec[k] = normals[:, i]
    if colors is not None:
        for i, k in enumerate(("red", "green", "blue")):
            rec[k] = colors[:, i]
    ply_type = {"f4": "float", "u1": "uchar"}
    fmt = "binary_little_endian" if binary else "ascii"
    head = [f"ply\nformat {fmt} 1.0\nelement vertex {len(pts)}"]
    head += [f"property {ply_type[t]} {k}" for k, t in names]
    head.append("end_header\n")
    header = "\n".join(head).encode("ascii")
    if binary:
        return header + rec.tobytes()
    body = _io.StringIO()
    fmts = ["%.9g" if t == "f4" else "%d" for _, t in names]
    np.savetxt(body, np.column_stack([rec[k] for k, _ in names]), fmt=fmts)
    return header + body.getvalue().encode("ascii")
