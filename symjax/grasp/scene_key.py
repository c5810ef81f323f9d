"""What the jitted control schedule and labels of a :class:`GraspScene` depend on.

A scene's structure (hand, simulation config, model sizes, index tables) is a hashable key; its
object-dependent values (mass, radius, per-geom tables padded to a geom bucket) are arrays passed
to the compiled function. So a new object of the same hand and config reuses the compiled
functions instead of recompiling them (about 7 s per scene on the 2-core CPU before).
"""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np

from symjax.geometry import bucket
from symjax.grasp.scene import GraspScene

__all__ = ["bind", "object_arrays", "static_key"]

_OBJECT_FIELDS = ("mass", "radius", "geom_finger", "geom_object", "geom_table")


def _geom_rows(scene: GraspScene) -> int:
    """The geom tables' padded length: a bucket of the model's geom count."""
    return bucket(scene.model.ngeom, minimum=32)


def static_key(scene: GraspScene) -> tuple:
    """Hashable structure of a scene: equal keys compile to the same functions."""
    m = scene.model

    def t(x):
        return tuple(int(i) for i in np.ravel(x))

    return (
        scene.hand.name, len(scene.hand.finger_names), scene.config,
        m.nq, m.nv, m.nu, m.neq, _geom_rows(scene),
        tuple(float(g) for g in m.opt.gravity),
        t(scene.qadr_base), t(scene.qadr_hand), scene.qadr_object, scene.dadr_object,
        t(scene.act_slide), t(scene.act_hinge), t(scene.act_hand), scene.weld,
    )  # fmt: skip


def object_arrays(scene: GraspScene) -> dict[str, np.ndarray]:
    """The object-dependent fields, geom tables padded to the key's geom bucket.

    Padded geoms are neither hand (-1), object nor table; contacts never name them.
    """
    pad = _geom_rows(scene) - scene.model.ngeom

    def padded(x, fill):
        x = np.asarray(x)
        return np.concatenate([x, np.full(pad, fill, x.dtype)])

    return {
        "mass": np.float32(scene.mass),
        "radius": np.float32(scene.radius),
        "geom_finger": padded(scene.geom_finger, -1),
        "geom_object": padded(scene.geom_object, False),
        "geom_table": padded(scene.geom_table, False),
    }


def bind(template: GraspScene, arrays: dict[str, Any]) -> GraspScene:
    """``template`` with its object fields replaced by ``arrays`` (traced values inside jit)."""
    return dataclasses.replace(template, **{k: arrays[k] for k in _OBJECT_FIELDS})
