"""One benchmark view as a compressed ``.npz`` file, and back."""

from __future__ import annotations

import io
import json
import zipfile
from pathlib import Path

import numpy as np

from symjax.camera import Camera
from symjax.datasets.objects import ObjectModel
from symjax.datasets.render import GENERATOR_VERSION
from symjax.datasets.view import View
from symjax.errors import FileFormatError
from symjax.observation import Observation
from symjax.table import TablePlane

__all__ = ["decode_view", "encode_view", "view_file_name"]


def encode_view(view: View) -> bytes:
    obs = view.observation
    meta = {
        "generator_version": GENERATOR_VERSION,
        "name": view.name,
        "dataset": view.dataset,
        "object_name": view.object_name,
        "orientation_deg": view.orientation_deg,
        "symmetry": view.symmetry,
        "symmetry_planes": None
        if view.symmetry_planes is None
        else [[np.asarray(n).tolist(), float(o)] for n, o in view.symmetry_planes],
        "symmetry_axis": None
        if view.symmetry_axis is None
        else [np.asarray(x).tolist() for x in view.symmetry_axis],
        "source": view.source,
        "width": obs.camera.width,
        "height": obs.camera.height,
        "meta": view.meta,
    }
    arrays = {
        "points": np.asarray(obs.points, np.float32),
        "mask": np.asarray(obs.mask, bool),
        "obj_depth": np.asarray(obs.depth, np.float32),
        "depth": np.asarray(view.depth, np.float32),
        "flying": np.asarray(view.flying, bool),
        "K": np.asarray(obs.camera.K, np.float64),
        "T_world_cam": np.asarray(obs.camera.T_world_cam, np.float64),
        "gt_pose": np.asarray(view.gt_pose, np.float64),
        "meta": np.array(json.dumps(meta)),
    }
    # A plain .npz (np.load reads it), deflated at level 1: noisy depth barely compresses
    # further at higher levels, which cost several times the time.
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w", zipfile.ZIP_DEFLATED, compresslevel=1) as zf:
        for key, arr in arrays.items():
            with zf.open(key + ".npy", "w", force_zip64=True) as f:
                np.lib.format.write_array(f, arr, allow_pickle=False)
    return buf.getvalue()


def decode_view(path: Path, obj: ObjectModel | None) -> View:
    try:
        with np.load(path, allow_pickle=False) as z:
            meta = json.loads(str(z["meta"]))
            arrays = {k: z[k] for k in z.files if k != "meta"}
    except Exception as e:
        raise FileFormatError(f"cannot read benchmark view {str(path)!r}: {e}") from e
    cam = Camera.create(arrays["K"], arrays["T_world_cam"], meta["width"], meta["height"])
    obs = Observation(
        points=arrays["points"],
        valid=np.ones(len(arrays["points"]), bool),
        table=TablePlane.horizontal(0.0),
        camera=cam,
        mask=arrays["mask"],
        depth=arrays["obj_depth"],
    )
    mesh = None
    if obj is not None:
        mesh = obj.mesh.copy()
        mesh.apply_transform(arrays["gt_pose"])
    planes = meta["symmetry_planes"]
    axis = meta["symmetry_axis"]
    return View(
        name=meta["name"],
        dataset=meta["dataset"],
        object_name=meta["object_name"],
        orientation_deg=float(meta["orientation_deg"]),
        observation=obs,
        depth=arrays["depth"],
        gt_mesh=mesh,
        gt_pose=arrays["gt_pose"],
        gt_diagonal=None if obj is None else obj.oriented_diagonal,
        symmetry=meta["symmetry"],
        symmetry_planes=None
        if planes is None
        else [(np.asarray(n, np.float64), float(o)) for n, o in planes],
        symmetry_axis=None if axis is None else tuple(np.asarray(x, np.float64) for x in axis),
        flying=arrays["flying"],
        source=meta["source"],
        meta=meta["meta"],
    )


def view_file_name(name: str) -> str:
    return name.replace("/", "_") + ".npz"
