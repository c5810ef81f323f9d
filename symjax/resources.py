"""Where symjax finds its packaged files and keeps its caches.

The MJCF assets and the named presets live in the checkout's top-level ``assets/`` and
``configs/`` folders; a wheel carries them as ``symjax/assets`` and ``symjax/presets``
(``pyproject.toml`` maps the folders). Both layouts are looked up here and nowhere else.

Every on-disk cache (the rendered benchmark, preprocessed objects, coacd hulls) lives under one
root: ``$SYMJAX_CACHE``, else ``~/.cache/symjax``.
"""

from __future__ import annotations

import os
from pathlib import Path

from symjax.errors import MissingFileError

__all__ = ["CACHE_ENV", "asset_dir", "cache_dir", "preset_dir"]

#: The one environment variable that moves every cache.
CACHE_ENV = "SYMJAX_CACHE"

_PACKAGE = Path(__file__).resolve().parent


def _packaged(installed: str, checkout: str) -> Path:
    # A wheel puts the folder inside the package; a checkout (editable install) has it beside.
    for path in (_PACKAGE / installed, _PACKAGE.parent / checkout):
        if path.is_dir():
            return path
    raise MissingFileError(
        f"symjax's {checkout}/ folder is missing (looked in {_PACKAGE / installed} and"
        f" {_PACKAGE.parent / checkout}); reinstall symjax"
    )


def asset_dir() -> Path:
    """Folder of the MJCF hands and robots (``hands/<name>/``, ``robots/<name>/``)."""
    return _packaged("assets", "assets")


def preset_dir() -> Path:
    """Folder of the named TOML presets (``paper.toml``, ``default.toml``, ...)."""
    return _packaged("presets", "configs")


def cache_dir(kind: str) -> Path:
    """Cache folder of one kind (``"benchmark"``, ``"objects"``, ``"coacd"``).

    Args:
        kind: Sub-folder name.

    Returns:
        ``$SYMJAX_CACHE/<kind>``, else ``~/.cache/symjax/<kind>`` (not created here).
    """
    root = os.environ.get(CACHE_ENV)
    base = Path(root).expanduser() if root else Path.home() / ".cache" / "symjax"
    return base / kind
