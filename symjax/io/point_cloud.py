"""Point clouds from and to files: PLY, PCD (ASCII and binary) and NPZ.

PLY is read by trimesh; PCD by a small parser of its header (``FIELDS``/``SIZE``/``TYPE``/
``COUNT``/``POINTS``/``VIEWPOINT``/``DATA``) for ``ascii`` and ``binary`` data
(``binary_compressed`` raises :class:`~symjax.errors.FileFormatError`). NPZ holds ``points``
(N, 3) and optionally ``colors`` (N, 3) uint8, ``normals`` (N, 3) and ``viewpoint`` (3,).
"""

from __future__ import annotations

import dataclasses
import io as _io
import os
from pathlib import Path
from typing import Any

import numpy as np

from symjax._atomic import atomic_write_bytes
from symjax.camera import Camera
from symjax.errors import InvalidInputError, ShapeError, SymjaxError
from symjax.io._common import existing_file, format_error
from symjax.observation import MaskFill, Observation
from symjax.table import TablePlane

__all__ = [
    "PointCloud",
    "cloud_observation",
    "read_point_cloud",
    "write_point_cloud",
]

#: Point-cloud suffixes that :func:`read_point_cloud` and :func:`write_point_cloud` know.
CLOUD_FORMATS = (".ply", ".pcd", ".npz")


@dataclasses.dataclass(frozen=True)
class PointCloud:
    """A point cloud read from a file.

    Attributes:
        points: (N, 3) float64, metres (after the loader's ``scale``); non-finite rows dropped.
        colors: (N, 3) uint8 RGB, or None.
        normals: (N, 3) float64, or None.
        viewpoint: Sensor origin (3,) in the cloud's frame, metres, or None when the file has none.
    """

    points: np.ndarray
    colors: np.ndarray | None = None
    normals: np.ndarray | None = None
    viewpoint: np.ndarray | None = None


# -- reading ------------------------------------------------------------------------------------


def _finish(path: Path, points, colors=None, normals=None, viewpoint=None, scale=1.0) -> PointCloud:
    pts = np.asarray(points, dtype=np.float64)
    if pts.ndim != 2 or pts.shape[1] != 3:
        raise format_error(path, f"points must have shape (N, 3), got {pts.shape}")
    if pts.shape[0] == 0:
        raise format_error(path, "the cloud has no points")
    keep = np.all(np.isfinite(pts), axis=1)
    if not keep.any():
        raise format_error(path, f"all {len(pts)} points are NaN or inf")

    def rows(a, dtype):
        if a is None:
            return None
        a = np.asarray(a)
        if a.shape != pts.shape:
            raise format_error(path, f"per-point array of shape {a.shape}, expected {pts.shape}")
        return a[keep].astype(dtype)

    vp = None
    if viewpoint is not None:
        vp = np.asarray(viewpoint, dtype=np.float64).reshape(-1)
        if vp.shape != (3,) or not np.all(np.isfinite(vp)):
            raise format_error(path, f"viewpoint must be 3 finite numbers, got {vp}")
        vp = vp * scale
    return PointCloud(
        points=pts[keep] * scale,
        colors=rows(colors, np.uint8),
        normals=rows(normals, np.float64),
        viewpoint=vp,
    )


def _read_ply(path: Path, scale: float) -> PointCloud:
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
    return _finish(path, verts, colors, normals, None, scale)


# PCD TYPE letter and SIZE in bytes -> numpy dtype code.
_PCD_TYPES = {(t, s): f"{t.lower()}{s}" for t in "IU" for s in (1, 2, 4, 8)}
_PCD_TYPES.update({("F", 4): "f4", ("F", 8): "f8"})


def _read_pcd(path: Path, scale: float) -> PointCloud:
    raw = path.read_bytes()
    header: dict[str, list[str]] = {}
    pos = 0
    while True:
        end = raw.find(b"\n", pos)
        if end < 0:
            raise format_error(path, "PCD header has no DATA line (truncated or not a PCD)")
        try:
            line = raw[pos:end].decode("ascii").strip()
        except UnicodeDecodeError:
            raise format_error(path, "PCD header is not ASCII text (not a PCD file)") from None
        pos = end + 1
        if not line or line.startswith("#"):
            continue
        key, *vals = line.split()
        header[key.upper()] = vals
        if key.upper() == "DATA":
            break
    try:
        fields = header["FIELDS"]
        n_fields = len(fields)
        sizes = [int(s) for s in header.get("SIZE", ["4"] * n_fields)]
        types = [t.upper() for t in header.get("TYPE", ["F"] * n_fields)]
        counts = [int(c) for c in header.get("COUNT", ["1"] * n_fields)]
        if "POINTS" in header:
            n = int(header["POINTS"][0])
        else:
            n = int(header["WIDTH"][0]) * int(header.get("HEIGHT", ["1"])[0])
        viewpoint = [float(v) for v in header["VIEWPOINT"]] if "VIEWPOINT" in header else None
        kind = header["DATA"][0].lower()
    except (KeyError, ValueError, IndexError) as e:
        raise format_error(path, f"bad PCD header ({type(e).__name__}: {e})") from None
    if not (len(sizes) == len(types) == len(counts) == n_fields) or n < 0:
        raise format_error(path, "PCD header FIELDS/SIZE/TYPE/COUNT lengths disagree")
    for axis in "xyz":
        if axis not in fields:
            raise format_error(path, f"PCD has no field {axis!r} (fields: {' '.join(fields)})")
    cols: dict[str, np.ndarray] = {}
    if kind == "ascii":
        text = raw[pos:].decode("ascii", errors="replace")
        try:
            values = np.array(text.split(), dtype=np.float64)
        except ValueError:
            raise format_error(path, "PCD ascii data holds a non-number") from None
        width = sum(counts)
        if values.size != n * width:
            raise format_error(
                path,
                f"PCD ascii data has {values.size} numbers, expected {n} x {width} (truncated?)",
            )
        table = values.reshape(n, width)
        start = 0
        for f, t, c in zip(fields, types, counts, strict=True):
            cols[f] = table[:, start] if c == 1 else table[:, start : start + c]
            if f in ("rgb", "rgba"):
                # Packed colour: an integer for TYPE U/I, the bits of a float32 for TYPE F.
                col = table[:, start]
                cols[f] = col.astype(np.float32) if t == "F" else col.astype(np.uint32)
            start += c
    elif kind == "binary":
        try:
            dtype = np.dtype(
                [
                    (f"{f}_{i}", "<" + _PCD_TYPES[(t, s)], (c,) if c > 1 else ())
                    for i, (f, t, s, c) in enumerate(zip(fields, types, sizes, counts, strict=True))
                ]
            )
        except KeyError as e:
            raise format_error(path, f"PCD field type/size {e.args[0]} is not supported") from None
        need = n * dtype.itemsize
        if len(raw) - pos < need:
            raise format_error(
                path, f"PCD binary data has {len(raw) - pos} bytes, expected {need} (truncated)"
            )
        arr = np.frombuffer(raw, dtype=dtype, count=n, offset=pos)
        for i, f in enumerate(fields):
            cols[f] = arr[f"{f}_{i}"]
    elif kind == "binary_compressed":
        raise format_error(
            path, "PCD DATA binary_compressed is not supported; re-save it as ascii or binary"
        )
    else:
        raise format_error(path, f"unknown PCD DATA kind {kind!r}; expected ascii or binary")
    pts = np.stack([cols["x"], cols["y"], cols["z"]], axis=1)
    colors = None
    key = "rgb" if "rgb" in cols else "rgba" if "rgba" in cols else None
    if key is not None:
        packed = np.asarray(cols[key])
        packed = packed.astype(np.float32).view(np.uint32) if packed.dtype.kind == "f" else packed
        packed = packed.astype(np.uint32)
        colors = np.stack([(packed >> 16) & 255, (packed >> 8) & 255, packed & 255], axis=1)
    normals = None
    if all(k in cols for k in ("normal_x", "normal_y", "normal_z")):
        normals = np.stack([cols["normal_x"], cols["normal_y"], cols["normal_z"]], axis=1)
    vp = None
    if viewpoint is not None:
        if len(viewpoint) != 7:
            raise format_error(path, f"PCD VIEWPOINT needs 7 numbers, got {len(viewpoint)}")
        vp = viewpoint[:3]
    return _finish(path, pts, colors, normals, vp, scale)


def _read_npz(path: Path, scale: float) -> PointCloud:
    try:
        with np.load(path, allow_pickle=False) as z:
            if "points" not in z:
                raise format_error(path, f"npz needs a 'points' array, found {list(z.keys())}")
            data = {k: z[k] for k in ("points", "colors", "normals", "viewpoint") if k in z}
    except SymjaxError:
        raise
    except Exception as e:
        raise format_error(path, f"cannot read the npz ({type(e).__name__}: {e})") from None
    return _finish(
        path,
        data["points"],
        data.get("colors"),
        data.get("normals"),
        data.get("viewpoint"),
        scale,
    )


def read_point_cloud(path: str | os.PathLike, scale: float = 1.0) -> PointCloud:
    """Reads a point cloud.

    Args:
        path: ``.ply``, ``.pcd`` or ``.npz`` file.
        scale: Metres per file unit (0.001 for a cloud stored in millimetres).

    Raises:
        MissingFileError: If the file does not exist.
        FileFormatError: Unknown suffix, corrupt or truncated data, missing x/y/z, no points.
    """
    p = existing_file(path, "point cloud")
    if not (np.isfinite(scale) and scale > 0):
        raise InvalidInputError(f"scale must be > 0 metres per unit, got {scale}")
    suffix = p.suffix.lower()
    if suffix == ".ply":
        return _read_ply(p, scale)
    if suffix == ".pcd":
        return _read_pcd(p, scale)
    if suffix == ".npz":
        return _read_npz(p, scale)
    raise format_error(p, f"unknown point-cloud format {suffix!r}; expected one of {CLOUD_FORMATS}")


# -- writing ------------------------------------------------------------------------------------


def _check_rows(points, colors, normals):
    pts = np.asarray(points, dtype=np.float64)
    if pts.ndim != 2 or pts.shape[1] != 3:
        raise ShapeError(f"points must have shape (N, 3), got {pts.shape}")
    if colors is not None:
        colors = np.asarray(colors)
        if colors.shape != pts.shape:
            raise ShapeError(f"colors must have shape {pts.shape}, got {colors.shape}")
        colors = np.clip(colors, 0, 255).astype(np.uint8)
    if normals is not None:
        normals = np.asarray(normals, dtype=np.float64)
        if normals.shape != pts.shape:
            raise ShapeError(f"normals must have shape {pts.shape}, got {normals.shape}")
    return pts, colors, normals


def _ply_bytes(pts, colors, normals, binary: bool) -> bytes:
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


def _pcd_bytes(pts, colors, normals, binary: bool, viewpoint) -> bytes:
    fields = ["x", "y", "z"]
    cols = [pts[:, 0], pts[:, 1], pts[:, 2]]
    if normals is not None:
        fields += ["normal_x", "normal_y", "normal_z"]
        cols += [normals[:, 0], normals[:, 1], normals[:, 2]]
    if colors is not None:
        c = colors.astype(np.uint32)
        fields.append("rgb")
        cols.append((c[:, 0] << 16) | (c[:, 1] << 8) | c[:, 2])
    vp = [0.0, 0.0, 0.0] if viewpoint is None else [float(v) for v in np.ravel(viewpoint)]
    n = len(pts)
    # Packed colour as an unsigned integer: ASCII files then hold readable numbers.
    types = ["U" if f == "rgb" else "F" for f in fields]
    header = (
        "# .PCD v0.7 - written by symjax\nVERSION 0.7\n"
        f"FIELDS {' '.join(fields)}\nSIZE {' '.join('4' * len(fields))}\n"
        f"TYPE {' '.join(types)}\nCOUNT {' '.join('1' * len(fields))}\n"
        f"WIDTH {n}\nHEIGHT 1\nVIEWPOINT {vp[0]} {vp[1]} {vp[2]} 1 0 0 0\nPOINTS {n}\n"
        f"DATA {'binary' if binary else 'ascii'}\n"
    ).encode("ascii")
    rec = np.empty(n, dtype=[(f, "<u4" if f == "rgb" else "<f4") for f in fields])
    for f, c in zip(fields, cols, strict=True):
        rec[f] = c
    if binary:
        return header + rec.tobytes()
    lines = [rec[f].astype(str) for f in fields]
    body = "\n".join(" ".join(row) for row in zip(*lines, strict=True))
    return header + body.encode("ascii") + b"\n"


def write_point_cloud(
    path: str | os.PathLike,
    points: Any,
    colors: Any = None,
    normals: Any = None,
    binary: bool = True,
    viewpoint: Any = None,
) -> Path:
    """Writes a point cloud atomically; the format follows the suffix.

    Args:
        path: ``.ply``, ``.pcd`` or ``.npz``.
        points: (N, 3) metres, e.g. :meth:`SymmetryResult.completed_cloud`.
        colors: Optional (N, 3) RGB bytes.
        normals: Optional (N, 3).
        binary: Binary (default) or ASCII data for PLY and PCD.
        viewpoint: Optional sensor origin (3,), stored by PCD and NPZ.

    Raises:
        ShapeError: If arrays have the wrong shape.
        FileFormatError: If the suffix is not a known format.
    """
    p = Path(path)
    pts, colors, normals = _check_rows(points, colors, normals)
    suffix = p.suffix.lower()
    if suffix == ".ply":
        data = _ply_bytes(pts, colors, normals, binary)
    elif suffix == ".pcd":
        data = _pcd_bytes(pts, colors, normals, binary, viewpoint)
    elif suffix == ".npz":
        buf = _io.BytesIO()
        arrays = {"points": pts}
        if colors is not None:
            arrays["colors"] = colors
        if normals is not None:
            arrays["normals"] = normals
        if viewpoint is not None:
            arrays["viewpoint"] = np.asarray(viewpoint, np.float64).reshape(3)
        np.savez_compressed(buf, **arrays)
        data = buf.getvalue()
    else:
        raise format_error(
            p, f"unknown point-cloud format {suffix!r}; expected one of {CLOUD_FORMATS}"
        )
    return atomic_write_bytes(p, data)


# -- to an observation --------------------------------------------------------------------------


def cloud_observation(
    points: Any,
    table: TablePlane,
    camera: Camera | None = None,
    viewpoint: Any = None,
    K: Any = None,
    width: int = 640,
    height: int = 480,
    up: Any = (0.0, 0.0, 1.0),
    fill: MaskFill = "close",
) -> Observation:
    """An :class:`Observation` of one object's cloud seen by a camera or from a viewpoint only.

    With only a viewpoint, a virtual camera is placed there looking at the cloud's centroid (the
    reference implementation's convention) with intrinsics ``K`` and the image's up along ``up``;
    the mask and depth image are rendered by projecting the points.

    Args:
        points: (N, 3) object points, metres, world frame.
        table: The supporting plane.
        camera: The camera, if known (then ``viewpoint``/``K`` are ignored).
        viewpoint: Sensor origin (3,), metres, used when ``camera`` is None.
        K: Intrinsics (3, 3) of the virtual camera; default: focal 1.2 x width, centred.
        width: Virtual image width, pixels.
        height: Virtual image height, pixels.
        up: World direction shown as up in the virtual image.
        fill: Mask fill, see :meth:`Observation.from_points`.

    Raises:
        InvalidInputError: Neither a camera nor a viewpoint.
    """
    pts = np.asarray(points, dtype=np.float64)
    if camera is None:
        if viewpoint is None:
            raise InvalidInputError("need a camera or a viewpoint (3,) to observe a cloud from")
        if pts.ndim != 2 or pts.shape[1] != 3:
            raise ShapeError(f"points must have shape (N, 3), got {pts.shape}")
        finite = pts[np.all(np.isfinite(pts), axis=1)]
        target = finite.mean(axis=0) if len(finite) else np.zeros(3)
        if K is None:
            f = 1.2 * width
            K = np.array([[f, 0.0, width / 2.0], [0.0, f, height / 2.0], [0.0, 0.0, 1.0]])
        camera = Camera.look_at(viewpoint, target, K, width, height, up=up)
    return Observation.from_points(pts, camera, table, fill=fill)
