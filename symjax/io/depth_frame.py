"""Depth frames from files: a depth image in metres, the camera that took it, optional RGB.

Depth is read from a 16-bit PNG (integer units times a depth scale, e.g. 0.001 for millimetres) or
from ``.npy``/``.npz`` float arrays already in metres. The camera comes from a small JSON file:

.. code-block:: json

    {
      "width": 640, "height": 480,
      "K": [[fx, 0, cx], [0, fy, cy], [0, 0, 1]],
      "T_world_cam": [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]],
      "depth_scale": 0.001
    }

``K`` may be replaced by the keys ``fx``, ``fy``, ``cx``, ``cy`` (pixels). ``T_world_cam`` (camera
to world, metres, OpenCV axes: x right, y down, z forward) is optional and defaults to the identity
(world frame = camera frame). ``depth_scale`` (metres per PNG unit) is required for PNG depth unless
it is passed to :func:`load_depth_frame`; it is ignored for float depth.
"""

from __future__ import annotations

import dataclasses
import json
import os
from pathlib import Path
from typing import Any

import numpy as np

from symjax._atomic import atomic_write_bytes, atomic_write_json
from symjax.array_types import ArrayLike
from symjax.camera import Camera
from symjax.errors import InvalidInputError, MissingFileError, SymjaxError
from symjax.io._common import existing_file, format_error

__all__ = [
    "DepthFrame",
    "load_camera_json",
    "load_depth_frame",
    "read_depth_image",
    "write_camera_json",
    "write_depth_png",
]

#: Largest plausible median depth in metres; larger values are taken as a unit error (millimetres).
MAX_PLAUSIBLE_DEPTH = 20.0


@dataclasses.dataclass(frozen=True)
class DepthFrame:
    """One frame of a depth camera.

    Attributes:
        depth: Depth image (H, W), float32, metres along the optical axis; 0 = no measurement.
        camera: The camera (intrinsics and pose) with ``camera.height, camera.width == H, W``.
        rgb: Optional colour image (H, W, 3), uint8, RGB order.
    """

    depth: np.ndarray
    camera: Camera
    rgb: np.ndarray | None = None

    def points(self) -> np.ndarray:
        """The measured points (M, 3), world frame, metres, in row-major pixel order."""
        pts, valid = self.camera.backproject(self.depth)
        return np.asarray(pts)[np.asarray(valid)]


def _number(path: Path, data: dict, key: str) -> float:
    if key not in data:
        raise format_error(path, f"missing key {key!r} (see the camera JSON schema)")
    if isinstance(data[key], bool) or not isinstance(data[key], int | float):
        raise format_error(path, f"key {key!r} must be a number, got {data[key]!r}")
    try:
        value = float(data[key])
    except (TypeError, ValueError):
        raise format_error(path, f"key {key!r} must be a number, got {data[key]!r}") from None
    if not np.isfinite(value):
        raise format_error(path, f"key {key!r} must be finite, got {value}")
    return value


def _matrix(path: Path, data: dict, key: str, shape: tuple[int, int]) -> np.ndarray:
    try:
        m = np.asarray(data[key], dtype=np.float64)
    except (TypeError, ValueError):
        raise format_error(path, f"key {key!r} must be a {shape} array of numbers") from None
    if m.shape != shape:
        raise format_error(path, f"key {key!r} must have shape {shape}, got {m.shape}")
    return m


def load_camera_json(path: str | os.PathLike) -> tuple[Camera, float | None]:
    """Reads a camera from the JSON schema of this module.

    Args:
        path: The JSON file.

    Returns:
        ``(camera, depth_scale)``; ``depth_scale`` (metres per PNG unit) is None when absent.

    Raises:
        MissingFileError: If the file does not exist.
        FileFormatError: If it is not valid JSON, misses a key, or holds an invalid camera.
    """
    p = existing_file(path, "camera JSON")
    try:
        data = json.loads(p.read_text(encoding="utf-8"))
    except (UnicodeDecodeError, json.JSONDecodeError) as e:
        raise format_error(p, f"not valid JSON ({e})") from None
    if not isinstance(data, dict):
        raise format_error(p, f"expected a JSON object, got {type(data).__name__}")
    width, height = _number(p, data, "width"), _number(p, data, "height")
    if "K" in data:
        K = _matrix(p, data, "K", (3, 3))
    else:
        fx, fy = _number(p, data, "fx"), _number(p, data, "fy")
        cx, cy = _number(p, data, "cx"), _number(p, data, "cy")
        K = np.array([[fx, 0.0, cx], [0.0, fy, cy], [0.0, 0.0, 1.0]])
    T = _matrix(p, data, "T_world_cam", (4, 4)) if "T_world_cam" in data else np.eye(4)
    scale = _number(p, data, "depth_scale") if data.get("depth_scale") is not None else None
    if scale is not None and scale <= 0:
        raise format_error(p, f"depth_scale must be > 0 metres per unit, got {scale}")
    if width != int(width) or height != int(height):
        raise format_error(p, f"width and height must be integers, got {width}, {height}")
    try:
        cam = Camera.create(K, T, int(width), int(height))
    except SymjaxError as e:
        raise format_error(p, f"invalid camera: {e}") from None
    return cam, scale


def write_camera_json(
    path: str | os.PathLike, camera: Camera, depth_scale: float | None = None
) -> Path:
    """Writes ``camera`` (and the PNG depth scale, metres per unit) in this module's schema."""
    data: dict[str, Any] = {
        "width": int(camera.width),
        "height": int(camera.height),
        "K": np.asarray(camera.K, np.float64).tolist(),
        "T_world_cam": np.asarray(camera.T_world_cam, np.float64).tolist(),
    }
    if depth_scale is not None:
        data["depth_scale"] = float(depth_scale)
    return atomic_write_json(path, data)


def read_depth_image(path: str | os.PathLike, depth_scale: float | None = None) -> np.ndarray:
    """Reads a depth image in metres.

    Args:
        path: ``.png`` (16-bit), ``.npy`` or ``.npz`` (key ``depth``, or its only array).
        depth_scale: Metres per unit. Required for PNG; for ``.npy``/``.npz`` it converts integer
            arrays and is otherwise ignored (float arrays are taken as metres).

    Returns:
        float32 (H, W) metres, 0 where there is no measurement (NaN/inf/0 in the file).

    Raises:
        MissingFileError: If the file does not exist.
        FileFormatError: Corrupt or truncated file, unknown suffix, not 2-D, a PNG without a
            depth scale or not 16-bit, negative depth, or values that look like millimetres.
    """
    p = existing_file(path, "depth image")
    suffix = p.suffix.lower()
    if suffix == ".png":
        import cv2

        raw = cv2.imread(str(p), cv2.IMREAD_UNCHANGED)
        if raw is None:
            raise format_error(p, "cannot decode the PNG (corrupt or truncated)")
        if raw.dtype != np.uint16 or raw.ndim != 2:
            raise format_error(
                p,
                f"depth PNG must be single-channel 16-bit, got {raw.dtype} with shape {raw.shape}",
            )
        if depth_scale is None:
            raise format_error(
                p,
                "16-bit depth PNG without a depth scale: its units are unknown; pass depth_scale "
                "(metres per unit, e.g. 0.001 for millimetres) or set 'depth_scale' in the JSON",
            )
        depth = raw.astype(np.float64) * float(depth_scale)
    elif suffix in (".npy", ".npz"):
        try:
            loaded = np.load(p, allow_pickle=False)
            if suffix == ".npz":
                with loaded:
                    keys = list(loaded.keys())
                    if "depth" in keys:
                        arr = loaded["depth"]
                    elif len(keys) == 1:
                        arr = loaded[keys[0]]
                    else:
                        raise format_error(p, f"npz needs a 'depth' array, found keys {keys}")
            else:
                arr = loaded
        except SymjaxError:
            raise
        except Exception as e:  # numpy raises many types on corrupt input
            raise format_error(p, f"cannot read the array ({type(e).__name__}: {e})") from None
        arr = np.asarray(arr)
        if arr.dtype.kind in "iu":
            if depth_scale is None:
                raise format_error(
                    p, f"integer depth ({arr.dtype}) without a depth scale: units are unknown"
                )
            depth = arr.astype(np.float64) * float(depth_scale)
        elif arr.dtype.kind == "f":
            depth = arr.astype(np.float64)
        else:
            raise format_error(p, f"depth array must be numeric, got dtype {arr.dtype}")
    else:
        raise format_error(p, f"unknown depth format {suffix!r}; expected .png, .npy or .npz")
    if depth.ndim != 2:
        raise format_error(p, f"depth image must be 2-D (H, W), got shape {depth.shape}")
    depth = np.where(np.isfinite(depth), depth, 0.0)
    if np.any(depth < 0):
        raise format_error(p, "depth has negative values; expected metres >= 0 (0 = none)")
    measured = depth[depth > 0]
    if measured.size and np.median(measured) > MAX_PLAUSIBLE_DEPTH:
        integer = suffix == ".png" or arr.dtype.kind in "iu"
        fix = (
            f"the depth scale {depth_scale} makes it so; for millimetres pass depth_scale=0.001"
            if integer
            else "float depth must be metres: divide it by 1000 (depth_scale applies to"
            " integer depth only)"
        )
        raise format_error(
            p, f"median depth is {np.median(measured):.1f} m; expected metres (millimetres? {fix})"
        )
    return depth.astype(np.float32)


def load_depth_frame(
    depth_path: str | os.PathLike,
    camera: Camera | str | os.PathLike | None = None,
    rgb_path: str | os.PathLike | None = None,
    depth_scale: float | None = None,
) -> DepthFrame:
    """Loads a depth frame with its camera.

    Args:
        depth_path: Depth image, see :func:`read_depth_image`.
        camera: A :class:`Camera`, a camera JSON path, or None to use ``<depth stem>.json`` or
            ``camera.json`` beside the depth image.
        rgb_path: Optional colour image (any format OpenCV reads), same size as the depth.
        depth_scale: Metres per PNG unit; overrides the JSON's ``depth_scale``.

    Raises:
        MissingFileError: A file (or the camera JSON when looked up beside the depth) is missing.
        FileFormatError: See :func:`read_depth_image` and :func:`load_camera_json`; also image
            sizes that do not match the camera.
    """
    dp = existing_file(depth_path, "depth image")
    json_scale = None
    if camera is None:
        for cand in (dp.with_suffix(".json"), dp.parent / "camera.json"):
            if cand.is_file():
                camera = cand
                break
        else:
            raise MissingFileError(
                f"no camera for {dp}: pass camera= or put {dp.stem}.json or camera.json beside it"
            )
    if not isinstance(camera, Camera):
        camera, json_scale = load_camera_json(camera)
    scale = depth_scale if depth_scale is not None else json_scale
    depth = read_depth_image(dp, scale)
    hw = (camera.height, camera.width)
    if depth.shape != hw:
        raise format_error(dp, f"depth image is {depth.shape}, the camera expects {hw} (H, W)")
    rgb = None
    if rgb_path is not None:
        import cv2

        rp = existing_file(rgb_path, "colour image")
        bgr = cv2.imread(str(rp), cv2.IMREAD_COLOR)
        if bgr is None:
            raise format_error(rp, "cannot decode the colour image (corrupt or unknown format)")
        if bgr.shape[:2] != hw:
            raise format_error(rp, f"colour image is {bgr.shape[:2]}, the depth is {hw} (H, W)")
        rgb = np.ascontiguousarray(bgr[..., ::-1])
    return DepthFrame(depth=depth, camera=camera, rgb=rgb)


def write_depth_png(path: str | os.PathLike, depth: ArrayLike, depth_scale: float = 0.001) -> Path:
    """Writes a depth image (H, W) in metres as a 16-bit PNG of ``depth / depth_scale`` units.

    Raises:
        InvalidInputError: If the depth is not 2-D, not finite and >= 0, or overflows 16 bits.
    """
    import cv2

    d = np.asarray(depth, dtype=np.float64)
    if d.ndim != 2 or not np.all(np.isfinite(d)) or np.any(d < 0):
        raise InvalidInputError("depth must be a finite (H, W) array of metres >= 0")
    units = np.rint(d / depth_scale)
    if units.max(initial=0) > 65535:
        raise InvalidInputError(
            f"depth up to {d.max():.2f} m overflows 16 bits at depth_scale={depth_scale} m/unit"
        )
    ok, buf = cv2.imencode(".png", units.astype(np.uint16))
    if not ok:  # pragma: no cover - OpenCV always encodes uint16 PNG
        raise InvalidInputError("PNG encoding failed")
    return atomic_write_bytes(path, buf.tobytes())
