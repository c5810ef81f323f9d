"""Settings of :func:`symjax.data.generate_dataset`: the stage configs and the data set's spec."""

from __future__ import annotations

import dataclasses
import hashlib
import json

from symjax.configs.stages import ShapeToGraspStages
from symjax.data.spec import DatasetSpec

__all__ = ["DATA_VERSION", "GenerateConfig"]

#: Version of the sampling and labelling code; part of every shard key, bumped when a change
#: gives different labels for the same settings (older shards are then recomputed).
DATA_VERSION = 1


@dataclasses.dataclass(frozen=True)
class GenerateConfig(ShapeToGraspStages):
    """Parameters of a data-generation run.

    Attributes:
        generate: What the data set holds (objects, hands, counts, views): the preset's
            ``[generate]`` table.
        out_dir: Output folder: ``grasps/<hand>/<object>.h5``, ``meshes/<object>.obj``,
            ``manifest.json``.
        cache_dir: Folder of the preprocessed-object cache (None: the default).

    The stage configs are :class:`~symjax.configs.stages.ShapeToGraspStages`' (the symmetry
    search and Mir7 for the partial views, coacd, the generators, the rollouts).
    """

    generate: DatasetSpec = dataclasses.field(default_factory=DatasetSpec)
    out_dir: str = "out/grasps"
    cache_dir: str | None = None

    def shard_key(self, object_name: str, hand: str, mesh_digest: str) -> str:
        """Hash of what one shard's labels depend on: every numeric setting, the object and its
        mesh, the hand; not the output folder, the execution settings or the other objects."""
        d = dataclasses.asdict(self)
        for k in ("out_dir", "cache_dir", "execution"):
            d.pop(k)
        for k in ("objects", "mesh_folder", "scales", "default_scale", "hands"):
            d["generate"].pop(k)
        d.update(object=object_name, hand=hand, mesh=mesh_digest, version=DATA_VERSION)
        return hashlib.sha256(json.dumps(d, sort_keys=True).encode()).hexdigest()[:16]
