"""Symmetry completion of 24 synthetic views, end to end: ``symjax demo``.

Run ``python scripts/demo.py --help`` (or ``symjax demo --help``) for the options.
"""

from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from symjax.cli.demo_command import main as _main  # noqa: E402


def main(argv: list[str] | None = None) -> int:
    """The same as ``symjax demo``; returns the exit status."""
    return _main(sys.argv[1:] if argv is None else argv, prog="demo.py")


if __name__ == "__main__":
    sys.exit(main())
