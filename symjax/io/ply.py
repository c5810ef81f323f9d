"""PLY point clouds, read by trimesh and written ASCII or binary."""

from __future__ import annotations

import io as _io
from pathlib import Path

import numpy as np

from symjax.errors import SymjaxError
from symjax.io._common import format_error
from symjax.io.cloud_data import PointCloud, finish

__all__ = ["ply_bytes", "read_ply"]


def read_ply(path: Path, scale: float) -> PointCloud:
    import trimesh

    try:
        _check_body(path)
        geom = trimesh.load(str(path), file_type="ply", process=False)
    except SymjaxError:
        raise
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
def _check_body(path: Path) -> None:
    """An ASCII PLY must hold the rows its header declares (trimesh reads what is there)."""
    with open(path, "rb") as fh:
        head: list[str] = []
        for raw in fh:
            line = raw.decode("ascii", errors="replace").strip()
            head.append(line)
            if line == "end_header" or len(head) > 200:
                break
        if not head or head[0] != "ply" or "end_header" not in head:
            return  # not a PLY header: trimesh's own error says so
        if not any(h.startswith("format ascii") for h in head):
            return
        elements = [h.split() for h in head if h.startswith("element ")]
        counts = [(e[1], int(e[2])) for e in elements if len(e) == 3 and e[2].isdigit()]
        want = sum(c for _, c in counts)
        rows = sum(1 for raw in fh if raw.strip())
    if rows < want:
        what = ", ".join(f"{c} {name}" for name, c in counts)
        raise format_error(
            path,
            f"the header declares {what} ({want} rows) but the body holds {rows}: line"
            f" {len(head) + rows + 1} is missing (truncated file)",
        )


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
