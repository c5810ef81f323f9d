"""Typed exceptions raised by symjax.

Every error a user can provoke with bad input is a :class:`SymjaxError`. The subclasses also
derive from the matching built-in exception so that ``except ValueError`` style code keeps working.
Messages say what was wrong and what was expected.
"""

from __future__ import annotations

__all__ = [
    "SymjaxError",
    "InvalidInputError",
    "ShapeError",
    "EmptyInputError",
    "CameraError",
    "UnknownNameError",
    "MissingFileError",
    "FileFormatError",
    "DegenerateGeometryError",
    "ConfigError",
    "SimulationError",
    "OutputError",
]


class SymjaxError(Exception):
    """Base class of every error raised by symjax on bad input or an impossible request."""


class InvalidInputError(SymjaxError, ValueError):
    """A value is outside what the function accepts (NaN, negative size, wrong range...)."""


class ShapeError(InvalidInputError):
    """An array has the wrong shape or rank."""


class EmptyInputError(InvalidInputError):
    """A point cloud, mask or mesh is empty or has too few valid elements."""


class CameraError(InvalidInputError):
    """Invalid camera: bad intrinsics, non-rigid pose, or points behind the camera."""


class UnknownNameError(SymjaxError, KeyError):
    """A name (hand, robot, method, object, format) is not one of the known ones."""

    def __str__(self) -> str:  # KeyError quotes its message; keep it readable.
        return str(self.args[0]) if self.args else ""


class MissingFileError(SymjaxError, FileNotFoundError):
    """A required file or directory does not exist."""


class FileFormatError(SymjaxError, ValueError):
    """A file exists but is corrupt, truncated, or not in the expected format."""


class DegenerateGeometryError(InvalidInputError):
    """Geometry on which the operation is undefined (collinear or coplanar points, NaN normals)."""


class ConfigError(InvalidInputError):
    """A configuration value is invalid."""


class SimulationError(SymjaxError, RuntimeError):
    """A simulation could not be set up or run."""


class OutputError(SymjaxError, OSError):
    """An output folder cannot be written, or the disk has no room for what a job writes."""


def unknown_name(kind: str, name: object, valid: list[str] | tuple[str, ...]) -> UnknownNameError:
    """Builds an :class:`UnknownNameError` that lists the valid names."""
    return UnknownNameError(f"unknown {kind} {name!r}; expected one of: {', '.join(sorted(valid))}")


def config_or_default(value: object, cls: type, name: str = "config"):
    """``value`` when it is a ``cls``, ``cls()`` when None, else a :class:`ConfigError`.

    Args:
        value: What the caller passed.
        cls: The expected frozen config dataclass.
        name: The argument's name, for the message.
    """
    if value is None:
        return cls()
    if not isinstance(value, cls):
        raise ConfigError(f"{name} must be a {cls.__name__} or None, got {type(value).__name__}")
    return value


def one_line(e: BaseException, limit: int = 300) -> str:
    """``"<ErrorType>: <message>"``, first line only, at most ``limit`` characters: an error as
    a result file or a report row keeps it."""
    return f"{type(e).__name__}: {e}".splitlines()[0][:limit]
