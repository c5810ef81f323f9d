"""Convex decomposition (coacd) of object meshes and object MJCF built with ``mujoco.MjSpec``."""

from symjax.decompose.config import DecomposeConfig
from symjax.decompose.hulls import Decomposition, cap_hull, decompose, default_cache_dir, mesh_key
from symjax.decompose.mjcf_object import mass_properties, object_spec, object_xml

__all__ = [
    "DecomposeConfig",
    "Decomposition",
    "cap_hull",
    "decompose",
    "default_cache_dir",
    "mass_properties",
    "mesh_key",
    "object_spec",
    "object_xml",
]
