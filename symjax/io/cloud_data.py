"""The point-cloud record every reader returns, and the checks shared by readers and writers."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np

from symjax.errors import ShapeError
from symjax.io._common import format_error

__all__ = ["PointCloud", "check_rows", "finish"]


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


def finish(path: Path, points, colors=None, normals=None, viewpoint=None, scale=1.0) -> PointCloud:
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


def check_rows(points, colors, normals):
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
