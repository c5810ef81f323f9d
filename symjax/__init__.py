"""symjax: robotic grasping under incomplete observation, in JAX.

Symmetry-based shape completion (Bohg et al., "Mind the Gap", ICRA 2011), meshing, evaluation and
grasp simulation, vectorised with JAX and MJX.
"""

from symjax.camera import Camera
from symjax.errors import (
    CameraError,
    ConfigError,
    DegenerateGeometryError,
    EmptyInputError,
    FileFormatError,
    InvalidInputError,
    MissingFileError,
    ShapeError,
    SimulationError,
    SymjaxError,
    UnknownNameError,
)
from symjax.observation import Observation, stack_observations
from symjax.symmetry import SymmetryConfig, SymmetryResult, complete
from symjax.table import TablePlane

__version__ = "0.1.0"

# Pipeline stages as subpackages, imported on first use: `import symjax` stays light (no MuJoCo,
# no coacd) for users of the completion alone.
_SUBPACKAGES = (
    "cli",
    "configs",
    "datasets",
    "decompose",
    "evaluation",
    "execution",
    "geometry",
    "grasp",
    "hands",
    "io",
    "metrics",
    "perception",
    "resources",
    "robots",
    "surface",
    "symmetry",
)


def __getattr__(name: str):
    if name in _SUBPACKAGES:
        import importlib

        return importlib.import_module(f"symjax.{name}")
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
