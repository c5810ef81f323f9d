"""PCD point clouds (PCL's format): a small parser of the header (``FIELDS``/``SIZE``/``TYPE``/
``COUNT``/``POINTS``/``VIEWPOINT``/``DATA``) for ``ascii`` and ``binary`` data
(``binary_compressed`` raises :class:`~symjax.errors.FileFormatError`), and the writer.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from symjax.io._common import format_error
from symjax.io.cloud_data import PointCloud, finish

__all__ = ["pcd_bytes", "read_pcd"]

_PCD_TYPES = {(t, s): f"{t.lower()}{s}" for t in "IU" for s in (1, 2, 4, 8)}
_PCD_TYPES.update({("F", 4): "f4", ("F", 8): "f8"})


def read_pcd(path: Path, scale: float) -> PointCloud:
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
    for f, c in zip(fields, counts, strict=True):
        if c != 1 and f in ("x", "y", "z", "normal_x", "normal_y", "normal_z", "rgb", "rgba"):
            raise format_error(
                path,
                f"PCD field {f!r} has COUNT {c}; symjax reads x, y, z, normal_x/y/z and rgb(a)"
                " with COUNT 1 (other fields may have any COUNT)",
            )
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
    return finish(path, pts, colors, normals, vp, scale)


def pcd_bytes(pts, colors, normals, binary: bool, viewpoint) -> bytes:
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
