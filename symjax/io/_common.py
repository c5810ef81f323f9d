"""Shared helpers of the loaders: path checks and error wrapping."""

from __future__ import annotations

import os
from pathlib import Path

from symjax.errors import FileFormatError, MissingFileError

__all__ = ["existing_file", "format_error"]


def existing_file(path: str | os.PathLike, what: str) -> Path:
    """Returns ``path`` as a :class:`Path`, raising :class:`MissingFileError` if it is no file."""
    p = Path(path)
    if not p.is_file():
        raise MissingFileError(f"{what} {str(p)!r} does not exist or is not a file")
    return p


def format_error(path: Path, problem: str) -> FileFormatError:
    """A :class:`FileFormatError` whose message starts with the file name."""
    return FileFormatError(f"{path}: {problem}")
