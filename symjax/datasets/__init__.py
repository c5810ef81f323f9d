"""Data sets: the embedded 128-view benchmark, synthetic primitive scenes and the ray caster.

``symjax.datasets.benchmark(...)`` returns the benchmark's views; every data source yields
:class:`View` objects. Modules: ``catalogue`` (the 12 scanned objects, 16 data sets),
``preprocess`` (canonical object frame), ``mesh_symmetry`` (true symmetry planes), ``objects``
(cached object models), ``stereo`` (the simulated stereo head), ``render`` (views of an object),
``view_file`` (a view on disk), ``collection`` (the cached benchmark), ``view`` (the view type),
``raycast`` (display-free depth rendering), ``primitives`` (synthetic boxes and cylinders),
``scan_scenes`` (seeded table scenes of several scans for a robot, settled, from its head camera).
"""

from symjax.datasets.catalogue import DATASET_IDS, OBJECT_NAMES
from symjax.datasets.collection import Benchmark, benchmark, view_names
from symjax.datasets.objects import ObjectModel, load_dataset_object, load_object
from symjax.datasets.render import (
    GENERATOR_VERSION,
    ORIENTATIONS_DEG,
    BenchmarkConfig,
    render_view,
    render_views,
)
from symjax.datasets.scan_scenes import (
    SCENE_OBJECTS,
    ScanScene,
    head_camera,
    rearranged,
    scan_scene,
)
from symjax.datasets.stereo import StereoHead, StereoNoise
from symjax.datasets.view import View, symmetry_truth

__all__ = [
    "DATASET_IDS",
    "GENERATOR_VERSION",
    "OBJECT_NAMES",
    "ORIENTATIONS_DEG",
    "SCENE_OBJECTS",
    "Benchmark",
    "BenchmarkConfig",
    "ObjectModel",
    "StereoHead",
    "StereoNoise",
    "ScanScene",
    "View",
    "benchmark",
    "head_camera",
    "load_dataset_object",
    "load_object",
    "render_view",
    "render_views",
    "symmetry_truth",
    "rearranged",
    "scan_scene",
    "view_names",
]
