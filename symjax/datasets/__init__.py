"""Data sets: the embedded 128-view benchmark, synthetic primitive scenes and the ray caster.

``symjax.datasets.benchmark(...)`` returns the benchmark's views (see
:mod:`symjax.datasets.benchmark`); every data source yields :class:`View` objects.
Submodules: ``objects`` (the 12 scanned objects), ``stereo`` (the simulated stereo head),
``view`` (the view type), ``raycast`` (display-free depth rendering), ``primitives``.
"""

from symjax.datasets import raycast
from symjax.datasets.benchmark import (
    GENERATOR_VERSION,
    ORIENTATIONS_DEG,
    Benchmark,
    BenchmarkConfig,
    benchmark,
    render_views,
)
from symjax.datasets.objects import DATASET_IDS, OBJECT_NAMES, ObjectModel, load_object
from symjax.datasets.stereo import StereoHead, StereoNoise
from symjax.datasets.view import View, plane_error

__all__ = [
    "DATASET_IDS",
    "GENERATOR_VERSION",
    "OBJECT_NAMES",
    "ORIENTATIONS_DEG",
    "Benchmark",
    "BenchmarkConfig",
    "ObjectModel",
    "StereoHead",
    "StereoNoise",
    "View",
    "benchmark",
    "load_object",
    "plane_error",
    "raycast",
    "render_views",
]
