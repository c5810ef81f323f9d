"""The per-view format of the KTH database used by the paper (``segment_<deg>.crd``).

A view is three files (see ``../shared/kth_demo/README.md``):

- ``segment_<deg>.crd``: a first line ``N``, then ``N`` lines ``x y z u v r g b``; ``x y z`` in
  millimetres in a table-aligned frame (z = table normal), ``u v`` the pixel column and row in the
  left foveal image (640 x 480), ``r g b`` colour bytes.
- ``viewPoint_<deg>.txt``: the camera centre ``x y z`` (mm) in the same frame.
- ``calib.txt``: stereo calibration; symjax uses the left 3x3 intrinsics (the first 9 numbers)
  and the image size (numbers 43 and 44).

The reference code puts a virtual camera at the viewpoint looking at the cloud's centroid. The
``u v`` columns pin down the real camera's orientation too: the points are exactly the left
camera's back-projections of those pixels from the viewpoint, so the default ``camera="uv"`` fits
the rotation to them (closed form, orthogonal Procrustes) and the mask and depth image land on the
file's pixels; ``camera="look_at"`` is the reference code's virtual camera (on the demo view its
optical axis differs by 1.4 deg, ~50 px in the image).

The database layout is one folder per object (or all in one folder) holding ``segment_<deg>.crd``
and ``viewPoint_<deg>.txt`` for ``deg`` in 000, 045, ..., 315, with one ``calib.txt`` in the
folder or any parent up to the root given to :func:`load_kth_directory`.
"""

from __future__ import annotations

import dataclasses
import os
import re
import warnings
from pathlib import Path
from typing import Literal

import numpy as np

from symjax.camera import Camera
from symjax.errors import InvalidInputError, MissingFileError, SymjaxError
from symjax.io._common import existing_file, format_error
from symjax.observation import MaskFill, Observation, SceneLimits, render_points
from symjax.table import TablePlane

__all__ = [
    "KthCalibration",
    "KthView",
    "load_kth_directory",
    "load_kth_view",
    "read_kth_calibration",
    "read_kth_segment",
    "read_kth_viewpoint",
]

#: Millimetres -> metres.
MM = 1e-3

#: A ``camera="uv"`` fit whose RMS reprojection error (pixels) exceeds this falls back to look-at.
MAX_FIT_RMS_PX = 3.0

_SEGMENT = re.compile(r"^segment_(\d+)\.crd$", re.IGNORECASE)


@dataclasses.dataclass(frozen=True)
class KthCalibration:
    """The parts of ``calib.txt`` that symjax uses.

    Attributes:
        K_left: Left (foveal) camera intrinsics (3, 3), pixels.
        dist_left: Its 4 distortion coefficients (the ``u v`` columns are already undistorted).
        width: Image width, pixels.
        height: Image height, pixels.
    """

    K_left: np.ndarray
    dist_left: np.ndarray
    width: int
    height: int


@dataclasses.dataclass(frozen=True)
class KthView:
    """One loaded view.

    Attributes:
        observation: The object's :class:`Observation` (metres, table-aligned frame).
        name: Object name: the folder of the view relative to the loaded root ("" for the root).
        degree: Orientation of the object in degrees (from ``segment_<deg>.crd``), or -1.
        path: The ``.crd`` file.
        uv: The file's pixel columns and rows (N, 2), int, of the finite points.
        colors: RGB bytes (N, 3).
        fit_rms_px: RMS distance (pixels) between the camera's projection of the points and ``uv``.
    """

    observation: Observation
    name: str
    degree: int
    path: Path
    uv: np.ndarray
    colors: np.ndarray
    fit_rms_px: float

    def uv_consistency(self) -> dict[str, float]:
        """How well the observation's images agree with the file's ``u v`` columns.

        Returns:
            ``iou``: IoU of the pixels the points project to (before mask filling) with the
            ``u v`` pixels; ``mask_recall``: fraction of ``u v`` pixels inside the mask;
            ``max_px``: largest projection error, pixels; ``depth_max_err``: largest difference
            (metres) between the depth image at ``(v, u)`` and the point's camera depth.
        """
        obs = self.observation
        pts = obs.valid_points().astype(np.float64)
        hit, depth = render_points(pts, obs.camera)
        ref = np.zeros_like(hit)
        inside = (
            (self.uv[:, 0] >= 0)
            & (self.uv[:, 0] < obs.camera.width)
            & (self.uv[:, 1] >= 0)
            & (self.uv[:, 1] < obs.camera.height)
        )
        u, v = self.uv[inside, 0], self.uv[inside, 1]
        ref[v, u] = True
        uv_proj, z = obs.camera.project(pts)
        err = np.linalg.norm(np.asarray(uv_proj) - self.uv, axis=1)
        img = np.asarray(obs.depth)
        return {
            "iou": float((hit & ref).sum() / max((hit | ref).sum(), 1)),
            "mask_recall": float(np.asarray(obs.mask)[v, u].mean()),
            "max_px": float(err.max()),
            "depth_max_err": float(np.abs(img[v, u] - np.asarray(z)[inside]).max()),
        }


def _numbers(path: Path, what: str) -> np.ndarray:
    try:
        text = path.read_text(encoding="ascii")
        return np.array(text.split(), dtype=np.float64)
    except (UnicodeDecodeError, ValueError):
        raise format_error(path, f"{what} must hold only numbers (ASCII)") from None


def read_kth_segment(path: str | os.PathLike) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Reads a ``.crd`` file.

    Returns:
        ``(xyz, uv, rgb)``: points (N, 3) in the file's millimetres, float64; pixels (N, 2) int64;
        colours (N, 3) uint8. Rows with non-finite coordinates are dropped.

    Raises:
        MissingFileError: If the file does not exist.
        FileFormatError: Non-numeric content, a count line that disagrees with the rows
            (truncated file), or no points.
    """
    p = existing_file(path, "KTH segment file")
    vals = _numbers(p, "a .crd file")
    if vals.size == 0:
        raise format_error(p, "empty file; expected a point count then rows 'x y z u v r g b'")
    n = vals[0]
    if n != int(n) or n < 0:
        raise format_error(p, f"first number must be the point count, got {n}")
    n = int(n)
    # Rows of other lengths would shift every later number into the wrong column.
    lines = p.read_text(encoding="ascii").splitlines()
    last = max((i for i, line in enumerate(lines) if line.strip()), default=0)
    for i, line in enumerate(lines[1:], start=1):
        k = len(line.split())
        if k and k != 8:
            cut = " (the last row is cut short: truncated file)" if i == last and k < 8 else ""
            raise format_error(
                p, f"line {i + 1} has {k} numbers; every row holds 8 ('x y z u v r g b'){cut}"
            )
    rows = vals[1:]
    if rows.size != 8 * n:
        raise format_error(
            p,
            f"header says {n} points, i.e. {8 * n} numbers in rows 'x y z u v r g b', "
            f"found {rows.size} (truncated or wrong column count)",
        )
    if n == 0:
        raise format_error(p, "the segment has no points")
    table = rows.reshape(n, 8)
    keep = np.all(np.isfinite(table[:, :5]), axis=1)
    table = table[keep]
    if len(table) == 0:
        raise format_error(p, "no finite points")
    uv = table[:, 3:5]
    if not np.allclose(uv, np.rint(uv)):
        raise format_error(p, "columns 4-5 (u v) must be integer pixel coordinates")
    return (
        table[:, :3].copy(),
        np.rint(uv).astype(np.int64),
        np.clip(table[:, 5:8], 0, 255).astype(np.uint8),
    )


def read_kth_viewpoint(path: str | os.PathLike) -> np.ndarray:
    """Reads ``viewPoint_<deg>.txt``: the camera centre (3,) in millimetres."""
    p = existing_file(path, "KTH viewpoint file")
    vals = _numbers(p, "a viewpoint file")
    if vals.size != 3 or not np.all(np.isfinite(vals)):
        raise format_error(p, f"expected 3 finite numbers 'x y z' (mm), found {vals.size}")
    return vals


def read_kth_calibration(path: str | os.PathLike) -> KthCalibration:
    """Reads ``calib.txt`` (see the module docstring for the order of its numbers).

    Raises:
        FileFormatError: Fewer than 44 numbers, or an invalid left intrinsic matrix or size.
    """
    p = existing_file(path, "KTH calibration file")
    vals = _numbers(p, "calib.txt")
    if vals.size < 44:
        raise format_error(
            p, f"has {vals.size} numbers; expected at least 44 (K, dist, K, dist, t, q, F, size)"
        )
    K = vals[:9].reshape(3, 3)
    width, height = vals[42], vals[43]
    if width != int(width) or height != int(height) or width <= 0 or height <= 0:
        raise format_error(
            p, f"image size (numbers 43-44) must be positive integers, got {vals[42:44]}"
        )
    try:
        Camera.create(K, np.eye(4), int(width), int(height))
    except SymjaxError as e:
        raise format_error(p, f"left intrinsics (first 9 numbers) are invalid: {e}") from None
    return KthCalibration(
        K_left=K, dist_left=vals[9:13].copy(), width=int(width), height=int(height)
    )


def _fit_rotation(points: np.ndarray, uv: np.ndarray, centre: np.ndarray, K: np.ndarray):
    """Camera-to-world rotation (3, 3) best mapping the pixels' rays onto the points' directions."""
    rays = np.column_stack([uv.astype(np.float64), np.ones(len(uv))]) @ np.linalg.inv(K).T
    rays /= np.linalg.norm(rays, axis=1, keepdims=True)
    dirs = points - centre
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    U, _, Vt = np.linalg.svd(dirs.T @ rays)
    D = np.diag([1.0, 1.0, np.sign(np.linalg.det(U @ Vt))])
    return U @ D @ Vt


def _find_calib(folder: Path, root: Path | None) -> Path:
    here = folder.resolve()
    stop = root.resolve() if root is not None else here
    while True:
        cand = here / "calib.txt"
        if cand.is_file():
            return cand
        if here == stop or here.parent == here:
            break
        here = here.parent
    raise MissingFileError(f"no calib.txt in {folder} or its parents up to {stop}")


def load_kth_view(
    crd_path: str | os.PathLike,
    viewpoint_path: str | os.PathLike | None = None,
    calib_path: str | os.PathLike | None = None,
    camera: Literal["uv", "look_at"] = "uv",
    table_height: float | None = None,
    fill: MaskFill = "close",
    name: str = "",
    _root: Path | None = None,
) -> KthView:
    """Loads one view into an :class:`Observation` in metres.

    Args:
        crd_path: ``segment_<deg>.crd``.
        viewpoint_path: Default ``viewPoint_<deg>.txt`` beside it.
        calib_path: Default ``calib.txt`` beside it.
        camera: ``"uv"`` (default): camera at the viewpoint whose orientation is fitted to the
            ``u v`` columns (falls back to ``"look_at"`` with a warning when the fit is poorer than
            :data:`MAX_FIT_RMS_PX`); ``"look_at"``: the reference code's virtual camera at the
            viewpoint looking at the centroid, image up = table normal.
        table_height: Table height z in the file's frame, metres. Default: the 0.5th percentile of
            the points' z (the README: the table is near the lowest points, not at z = 0).
        fill: Mask fill, see :meth:`Observation.from_points`.
        name: Stored as :attr:`KthView.name`.

    Raises:
        MissingFileError: A file is missing.
        FileFormatError: A file is corrupt or truncated (the message names it).
        InvalidInputError: Unknown ``camera`` mode.
    """
    crd = existing_file(crd_path, "KTH segment file")
    m = _SEGMENT.match(crd.name)
    deg = int(m.group(1)) if m else -1
    if viewpoint_path is None:
        if m is None:
            raise InvalidInputError(
                f"{crd}: cannot derive the viewpoint file from a name not like segment_<deg>.crd; "
                "pass viewpoint_path"
            )
        viewpoint_path = crd.parent / f"viewPoint_{m.group(1)}.txt"
    if calib_path is None:
        calib_path = _find_calib(crd.parent, _root)
    if camera not in ("uv", "look_at"):
        raise InvalidInputError(f"camera must be 'uv' or 'look_at', got {camera!r}")
    xyz_mm, uv, rgb = read_kth_segment(crd)
    centre = read_kth_viewpoint(viewpoint_path) * MM
    cal = read_kth_calibration(calib_path)
    pts = xyz_mm * MM
    extent = float(np.max(np.ptp(pts, axis=0)))
    if extent < SceneLimits().min_extent:
        raise format_error(
            crd,
            f"the points span {extent * 1e3:.3g} mm after reading them as millimetres; the file"
            " looks like it is in metres, but the KTH format stores millimetres (multiply by 1000)",
        )
    dist = float(np.linalg.norm(centre - pts.mean(axis=0)))
    if dist < 0.05:
        raise format_error(
            viewpoint_path,
            f"the viewpoint is {dist * 1e3:.3g} mm from the points after reading it as"
            " millimetres; it looks like metres, but the KTH format stores millimetres",
        )
    look = Camera.look_at(centre, pts.mean(axis=0), cal.K_left, cal.width, cal.height)
    cam = look
    if camera == "uv":
        T = np.eye(4)
        T[:3, :3] = _fit_rotation(pts, uv, centre, cal.K_left)
        T[:3, 3] = centre
        fitted = Camera.create(cal.K_left, T, cal.width, cal.height)
        proj, _ = fitted.project(pts)
        rms = float(np.sqrt(np.mean(np.sum((np.asarray(proj) - uv) ** 2, axis=1))))
        if rms <= MAX_FIT_RMS_PX:
            cam = fitted
        else:
            warnings.warn(
                f"{crd}: the u v columns do not fit a camera at the viewpoint (RMS {rms:.1f} px); "
                "using the look-at virtual camera",
                stacklevel=2,
            )
    proj, _ = cam.project(pts)
    rms = float(np.sqrt(np.mean(np.sum((np.asarray(proj) - uv) ** 2, axis=1))))
    height = float(np.percentile(pts[:, 2], 0.5)) if table_height is None else float(table_height)
    try:
        obs = Observation.from_points(pts, cam, TablePlane.horizontal(height), fill=fill)
    except SymjaxError as e:
        raise type(e)(f"{crd}: {e}") from None
    return KthView(
        observation=obs, name=name, degree=deg, path=crd, uv=uv, colors=rgb, fit_rms_px=rms
    )


def load_kth_directory(root: str | os.PathLike, **kwargs) -> list[KthView]:
    """Loads every ``segment_<deg>.crd`` under ``root`` (searched recursively).

    Each view's ``viewPoint_<deg>.txt`` must be beside it; ``calib.txt`` is looked up in its folder
    and then in the parents up to ``root``. Views are sorted by object folder then degree.

    Args:
        root: The database folder (or one object's folder).
        **kwargs: Passed to :func:`load_kth_view` (``camera``, ``table_height``, ``fill``).

    Raises:
        MissingFileError: ``root`` is not a folder, holds no ``segment_<deg>.crd``, or a view lacks
            its viewpoint or calibration file.
        FileFormatError: A file is corrupt (the message names it).
    """
    base = Path(root)
    if base.is_file():
        raise InvalidInputError(f"{str(base)!r} is a file; expected a KTH database folder")
    if not base.is_dir():
        raise MissingFileError(f"KTH database folder {str(base)!r} does not exist")
    found = [p for p in base.rglob("*") if p.is_file() and _SEGMENT.match(p.name)]
    if not found:
        raise MissingFileError(f"no segment_<deg>.crd files under {base}")
    views = []
    for p in found:
        rel = p.parent.relative_to(base).as_posix()
        views.append(load_kth_view(p, name="" if rel == "." else rel, _root=base, **kwargs))
    return sorted(views, key=lambda v: (v.name, v.degree))
