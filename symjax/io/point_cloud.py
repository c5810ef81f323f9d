"""Point clouds from and to files: PLY, PCD (ASCII and binary) and NPZ.

PLY is read by trimesh; PCD by a small parser of its header (``FIELDS``/``SIZE``/``TYPE``/
``COUNT``/``POINTS``/``VIEWPOINT``/``DATA``) for ``ascii`` and ``binary`` data
(``binary_compressed`` raises :class:`~symjax.errors.FileFormatError`). NPZ holds ``points``
(N, 3) and optionally ``colors`` (N, 3) uint8, ``normals`` (N, 3) and ``viewpoint`` (3,).
"""

from __future__ import annotations

import io as _io
import os
from pathlib import Path

import numpy as np

from symjax._atomic import atomic_write_bytes
from symjax.array_types import ArrayLike
from symjax.camera import Camera
from symjax.errors import InvalidInputError, ShapeError, SymjaxError
from symjax.io._common import existing_file, format_error
from symjax.io.cloud_data import PointCloud, check_rows, finish
from symjax.io.pcd import pcd_bytes, read_pcd
from symjax.io.ply import ply_bytes, read_ply
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
    return finish(
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
        return read_ply(p, scale)
    if suffix == ".pcd":
        return read_pcd(p, scale)
    if suffix == ".npz":
        return _read_npz(p, scale)
    raise format_error(p, f"unknown point-cloud format {suffix!r}; expected one of {CLOUD_FORMATS}")


# -- writing ------------------------------------------------------------------------------------


def write_point_cloud(
    path: str | os.PathLike,
    points: ArrayLike,
    colors: ArrayLike = None,
    normals: ArrayLike = None,
    binary: bool = True,
    viewpoint: ArrayLike = None,
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
    pts, colors, normals = check_rows(points, colors, normals)
    suffix = p.suffix.lower()
    if suffix == ".ply":
        data = ply_bytes(pts, colors, normals, binary)
    elif suffix == ".pcd":
        data = pcd_bytes(pts, colors, normals, binary, viewpoint)
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
    points: ArrayLike,
    table: TablePlane,
    camera: Camera | None = None,
    viewpoint: ArrayLike = None,
    K: ArrayLike = None,
    width: int = 640,
    height: int = 480,
    up: ArrayLike = (0.0, 0.0, 1.0),
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
