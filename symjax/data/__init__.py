"""Grasp training data for learned graspers: ACRONYM-keyed HDF5 shards with partial views.

Modules: ``spec`` (what a data set holds: the ``[generate]`` preset table), ``config``
(:class:`GenerateConfig`), ``objects`` (objects by name or from a mesh folder),
``dense_sampler`` (the grasp-space sampler), ``candidate_mix`` (a shard's candidates),
``partial_views`` (views, completions, grasps planned on them), ``acronym_file`` (the file's keys
and its atomic writer), ``shard`` (one object's shards), ``manifest``, ``runner``
(:func:`generate_dataset`), ``ray_backend`` (Ray tasks), ``loader`` (:func:`load_grasps`).
"""

from symjax.data.acronym_file import KEYS
from symjax.data.config import GenerateConfig
from symjax.data.dense_sampler import DenseSamplerConfig, dense_candidates
from symjax.data.loader import GraspData, PartialView, load_grasps
from symjax.data.objects import ObjectEntry, resolve_objects
from symjax.data.runner import generate_dataset
from symjax.data.spec import GENERATORS, DatasetSpec

__all__ = [
    "GENERATORS",
    "KEYS",
    "DatasetSpec",
    "DenseSamplerConfig",
    "GenerateConfig",
    "GraspData",
    "ObjectEntry",
    "PartialView",
    "dense_candidates",
    "generate_dataset",
    "load_grasps",
    "resolve_objects",
]
