"""symjax: robotic grasping under incomplete observation, in JAX.

Symmetry-based shape completion (Bohg et al., "Mind the Gap", ICRA 2011), meshing, evaluation and
grasp simulation, vectorised with JAX and MJX.
"""

from symjax.errors import (
    CameraError,
    ConfigError,
    DegenerateGeometryError,
    EmptyInputError,
    FileFormatError,
    InvalidInputError,
    MissingFileError,
    OutputError,
    ShapeError,
    SimulationError,
    SymjaxError,
    UnknownNameError,
)

# Names of the core types, imported on first use (PEP 562) like the subpackages below: a bare
# `import symjax` loads no JAX, so the console can install its Ctrl-C handler before JAX starts.
_LAZY = {
    "Camera": "symjax.camera",
    "Observation": "symjax.observation",
    "SceneLimits": "symjax.observation",
    "stack_observations": "symjax.observation",
    "SymmetryConfig": "symjax.symmetry",
    "SymmetryResult": "symjax.symmetry",
    "complete": "symjax.symmetry",
    "TablePlane": "symjax.table",
}

__version__ = "0.1.0"

# Pipeline stages as subpackages, imported on first use: `import symjax` stays light (no MuJoCo,
# no coacd) for users of the completion alone.
_SUBPACKAGES = (
    "cli",
    "completion",
    "configs",
    "cycle",
    "data",
    "datasets",
    "decompose",
    "evaluation",
    "execution",
    "geometry",
    "grasp",
    "hands",
    "io",
    "metrics",
    "motion",
    "perception",
    "resources",
    "robots",
    "study",
    "surface",
    "symmetry",
)


def __getattr__(name: str):
    import importlib

    if name in _SUBPACKAGES:
        return importlib.import_module(f"symjax.{name}")
    if name in _LAZY:
        return getattr(importlib.import_module(_LAZY[name]), name)
    raise AttributeError(f"module 'symjax' has no attribute {name!r}")


__all__ = [
    "Camera",
    "CameraError",
    "ConfigError",
    "DegenerateGeometryError",
    "EmptyInputError",
    "FileFormatError",
    "InvalidInputError",
    "MissingFileError",
    "Observation",
    "OutputError",
    "SceneLimits",
    "ShapeError",
    "SimulationError",
    "SymjaxError",
    "SymmetryConfig",
    "SymmetryResult",
    "TablePlane",
    "UnknownNameError",
    "complete",
    "stack_observations",
]
