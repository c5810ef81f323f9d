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
