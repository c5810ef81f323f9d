"""Reading a shard back: :func:`load_grasps` returns typed arrays, checked."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path
from typing import Any

import numpy as np

from symjax.errors import FileFormatError, MissingFileError

__all__ = ["GraspData", "PartialView", "load_grasps"]


@dataclasses.dataclass(frozen=True)
class PartialView:
    """One partial view of a shard (see ``symjax.data.acronym_file.KEYS`` for frames and units).

    Attributes:
        depth: (H, W) float32 metres. mask: (H, W) bool. K: (3, 3). T_world_camera,
        T_world_object: (4, 4). points: (M, 3) world frame. plane: (4,) ``n . x = d``.
        completed: (K, 3) world frame. confidence: float. grasp_transforms: (G, 4, 4) object
        frame. predicted_success, true_success: (G,) bool.
    """

    depth: np.ndarray
    mask: np.ndarray
    K: np.ndarray
    T_world_camera: np.ndarray
    T_world_object: np.ndarray
    points: np.ndarray
    plane: np.ndarray
    completed: np.ndarray
    confidence: float
    grasp_transforms: np.ndarray
    predicted_success: np.ndarray
    true_success: np.ndarray


@dataclasses.dataclass(frozen=True)
class GraspData:
    """A shard's grasps and labels.

    Attributes:
        transforms: (N, 4, 4) hand (TCP) frames in the object frame, metres.
        success: (N,) bool, ACRONYM's ``object_in_gripper``.
        labels: symjax's per-grasp arrays by name (``force_closure``, ``epsilon``, ...).
        qualities: ACRONYM's ``grasps/qualities/flex`` arrays by name.
        object: ``object/*`` values (``file`` a str).
        gripper: ``type`` (str), ``configuration``, ``joint_names``, ``tcp_in_base``.
        preshape_names, generator_names: What the ``preshape`` and ``generator`` codes mean.
        views: The partial views.
        manifest_row: The shard's manifest row.
    """

    transforms: np.ndarray
    success: np.ndarray
    labels: dict[str, np.ndarray]
    qualities: dict[str, np.ndarray]
    object: dict[str, Any]
    gripper: dict[str, Any]
    preshape_names: tuple[str, ...]
    generator_names: tuple[str, ...]
    views: tuple[PartialView, ...]
    manifest_row: dict[str, Any]

    def __len__(self) -> int:
        return len(self.success)


def _value(ds: Any) -> Any:
    v = ds[()]
    if isinstance(v, bytes):
        return v.decode()
    if isinstance(v, np.ndarray) and v.dtype.kind == "S":
        return tuple(x.decode() for x in v)
    return v


def load_grasps(path: str | Path) -> GraspData:
    """Reads one shard written by ``symjax generate``.

    Raises:
        MissingFileError: No such file.
        FileFormatError: Not an HDF5 file, incomplete, or a required key is missing.
    """
    import h5py

    path = Path(path)
    if not path.is_file():
        raise MissingFileError(f"grasp file {str(path)!r} does not exist")
    try:
        f = h5py.File(path, "r")
    except OSError as e:
        raise FileFormatError(f"{str(path)!r} is not a readable HDF5 file ({e})") from None
    with f:
        if not f.attrs.get("symjax_complete", False):
            raise FileFormatError(f"{str(path)!r} is incomplete (interrupted while written)")
        try:
            T = np.asarray(f["grasps/transforms"], np.float64)
            ok = np.asarray(f["grasps/qualities/flex/object_in_gripper"]).astype(bool)
            qual = {k: np.asarray(v) for k, v in f["grasps/qualities/flex"].items()}
            labels = {k: np.asarray(v) for k, v in f["symjax"].items()}
            obj = {k: _value(v) for k, v in f["object"].items()}
            grip = {k: _value(v) for k, v in f["gripper"].items()}
            views = []
            for k in sorted(f.get("views", {}), key=int):
                g = f["views"][k]
                views.append(PartialView(
                    depth=np.asarray(g["depth"]), mask=np.asarray(g["mask"], bool),
                    K=np.asarray(g["camera/K"]),
                    T_world_camera=np.asarray(g["camera/T_world_camera"]),
                    T_world_object=np.asarray(g["T_world_object"]), points=np.asarray(g["points"]),
                    plane=np.asarray(g["completion/plane"]),
                    completed=np.asarray(g["completion/points"]),
                    confidence=float(g["completion/confidence"][()]),
                    grasp_transforms=np.asarray(g["grasps/transforms"]),
                    predicted_success=np.asarray(g["grasps/predicted_success"], bool),
                    true_success=np.asarray(g["grasps/true_success"], bool),
                ))  # fmt: skip
            names = json.loads(f.attrs["symjax_preshape_names"])
            gens = json.loads(f.attrs["symjax_generator_names"])
            row = json.loads(f.attrs["symjax_manifest_row"])
        except KeyError as e:
            raise FileFormatError(
                f"{str(path)!r} lacks {e}; expected a symjax grasp file"
            ) from None
    if T.shape != (len(ok), 4, 4):
        raise FileFormatError(f"{str(path)!r}: transforms {T.shape} for {len(ok)} labels")
    return GraspData(T, ok, labels, qual, obj, grip, tuple(names), tuple(gens), tuple(views), row)
