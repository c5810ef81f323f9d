"""One shard (object x hand) as an HDF5 file with ACRONYM's keys, symjax's labels beside them.

The file is written to a temporary name in the same folder and renamed when complete; the last
attribute written is ``symjax_complete``, so a file that has it and the right key is whole.
:data:`KEYS` documents every dataset (the README's table is made from it).
"""

from __future__ import annotations

import errno
import json
import os
from pathlib import Path
from typing import Any

import numpy as np

from symjax.errors import OutputError

__all__ = ["KEYS", "REQUIRED", "shard_status", "write_shard"]

# key -> (shape, unit and meaning). "object frame": the object's canonical frame (z up, its
# lowest point at z = 0, centred on its area centroid), the frame of object/file's vertices.
KEYS: dict[str, tuple[str, str]] = {
    "grasps/transforms": (
        "(N, 4, 4)",
        "hand frame (the TCP: z approach, x closing axis) in the"
        " object frame when the hand starts to close, metres",
    ),
    "grasps/qualities/flex/object_in_gripper": (
        "(N,) int",
        "1: the object stayed in the hand through lift and shake",
    ),
    "grasps/qualities/flex/object_motion_during_closing_linear": (
        "(N,)",
        "object displacement while closing, metres",
    ),
    "grasps/qualities/flex/object_motion_during_closing_angular": (
        "(N,)",
        "object rotation while closing, radians",
    ),
    "grasps/qualities/flex/object_motion_during_shaking_linear": (
        "(N,)",
        "object motion in the hand frame, lift and shake, metres",
    ),
    "grasps/qualities/flex/object_motion_during_shaking_angular": (
        "(N,)",
        "object rotation in the hand frame, radians",
    ),
    "object/file": ("bytes", "the mesh simulated, relative to the data set folder (OBJ, metres)"),
    "object/scale": ("()", "scale of object/file (1: it is written in metres)"),
    "object/com": ("(3,)", "centre of mass, object frame, metres"),
    "object/mass": ("()", "kg"),
    "object/inertia": ("(3, 3)", "inertia about the centre of mass, kg m^2"),
    "object/density": ("()", "kg/m^3"),
    "object/friction": ("()", "sliding friction coefficient of the object and table"),
    "object/volume": ("()", "m^3 (of the convex hulls simulated)"),
    "gripper/type": ("bytes", "sdh, barrett or parallel_jaw"),
    "gripper/configuration": ("(J,)", "the hand's joint positions in its open pre-shape"),
    "gripper/joint_names": ("(J,) bytes", "the hand's joints"),
    "gripper/tcp_in_base": ("(4, 4)", "the hand frame (TCP) in the hand's base (flange) frame"),
    "symjax/success": ("(N,) bool", "same as object_in_gripper"),
    "symjax/force_closure": ("(N,) bool", "contacts at grasp time in force closure"),
    "symjax/epsilon": ("(N,)", "Ferrari-Canny L1 quality of those contacts"),
    "symjax/n_fingers": ("(N,) int", "fingers touching the object at grasp time"),
    "symjax/penetration": ("(N,)", "deepest hand-object penetration at grasp time, metres"),
    "symjax/start_penetration": (
        "(N,)",
        "hand penetration of object or table at the start, metres",
    ),
    "symjax/table_contact": ("(N,) bool", "the hand touched the table at grasp time"),
    "symjax/lift": ("(N,)", "rise of the object over lift and shake, metres"),
    "symjax/diverged": ("(N,) bool", "the simulation diverged (labelled failed)"),
    "symjax/closed_joint_positions": (
        "(N, J)",
        "hand joints at grasp time, radians or metres, gripper/joint_names order",
    ),
    "symjax/preshape": ("(N,) int", "pre-shape index (attribute names)"),
    "symjax/approach": ("(N, 3)", "unit approach direction, object frame"),
    "symjax/roll": ("(N,)", "roll about the approach, radians"),
    "symjax/distance": ("(N,)", "start distance before the grasp point, metres"),
    "symjax/grasp_point": ("(N, 3)", "point the approach line passes through, object frame"),
    "symjax/travel": ("(N,)", "distance the hand moved before it stopped, metres"),
    "symjax/generator": (
        "(N,) int",
        "candidate source (attribute names: kth, uji, openrave, dense)",
    ),
    "views/<k>/depth": ("(H, W)", "the view's full depth image, metres (0: none)"),
    "views/<k>/mask": ("(H, W) bool", "the object's pixels"),
    "views/<k>/camera/K": ("(3, 3)", "intrinsics, pixels"),
    "views/<k>/camera/T_world_camera": (
        "(4, 4)",
        "camera to world (the view's frame: table"
        " at z = 0); camera axes x right, y down, z forward",
    ),
    "views/<k>/T_world_object": ("(4, 4)", "the object's pose in the view's world frame"),
    "views/<k>/points": ("(M, 3)", "observed points, world frame, metres"),
    "views/<k>/completion/plane": (
        "(4,)",
        "symmetry plane (nx, ny, nz, d): n . x = d, world frame; NaN when none",
    ),
    "views/<k>/completion/points": ("(K, 3)", "observed plus kept mirrored points, world frame"),
    "views/<k>/completion/confidence": (
        "()",
        "mean visibility plausibility of the mirrored points, 0 to 1",
    ),
    "views/<k>/grasps/transforms": (
        "(G, 4, 4)",
        "grasps planned on the completion (best"
        " first): hand frame in the object frame when the hand"
        " starts to close on the true object",
    ),
    "views/<k>/grasps/predicted_success": ("(G,) bool", "success on the completion"),
    "views/<k>/grasps/true_success": (
        "(G,) bool",
        "success of the same hand pose on the true object",
    ),
}

#: Datasets a complete shard must hold (what ACRONYM's loaders read, and symjax's labels).
REQUIRED = tuple(k for k in KEYS if not k.startswith("views/"))


def shard_status(path: Path, key: str) -> str:
    """``"complete"``, ``"missing"``, ``"stale"`` (other settings) or ``"damaged"``."""
    import h5py

    if not path.is_file():
        return "missing"
    try:
        with h5py.File(path, "r") as f:
            if not f.attrs.get("symjax_complete", False):
                return "damaged"
            if f.attrs.get("symjax_key", "") != key:
                return "stale"
            n = f["grasps/transforms"].shape[0]
            for k in REQUIRED:
                if k not in f:
                    return "damaged"
            if f["grasps/qualities/flex/object_in_gripper"].shape != (n,):
                return "damaged"
    except (OSError, KeyError, ValueError):
        return "damaged"
    return "complete"


def _put(group: Any, name: str, value: Any) -> None:
    if isinstance(value, (str, bytes)):
        group.create_dataset(name, data=np.bytes_(value))
    else:
        a = np.asarray(value)
        kw = {"compression": "gzip", "compression_opts": 4} if a.size > 256 else {}
        group.create_dataset(name, data=a, **kw)


def write_shard(path: Path, data: dict[str, Any], attrs: dict[str, Any]) -> None:
    """Writes ``{key: array}`` (keys as in :data:`KEYS`, ``views/<k>/...`` included) atomically.

    Raises:
        OutputError: The folder cannot be written or the disk is full (nothing is left behind).
    """
    import h5py

    path = Path(path)
    tmp = path.with_name(f".{path.name}.tmp-{os.getpid()}")
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        with h5py.File(tmp, "w") as f:
            for k, v in data.items():
                head, _, leaf = k.rpartition("/")
                _put(f.require_group(head) if head else f, leaf, v)
            for k, v in attrs.items():
                f.attrs[k] = json.dumps(v) if isinstance(v, (dict, list)) else v
            f.attrs["symjax_complete"] = True
        with open(tmp, "rb+") as fh:
            os.fsync(fh.fileno())
        os.replace(tmp, path)
    except OSError as e:
        tmp.unlink(missing_ok=True)
        full = e.errno in (errno.ENOSPC, errno.EDQUOT) or "No space" in str(e)
        what = "the disk is full" if full else f"it cannot be written ({e})"
        raise OutputError(
            f"shard {str(path)!r} was not written: {what}; expected a writable folder with room"
            " for the data set (complete shards are kept; rerun to resume)"
        ) from None
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
