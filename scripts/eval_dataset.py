"""The paper's mesh evaluation (Bohg et al. 2011, Section V-A/V-B): ``symjax eval``.

Run ``python scripts/eval_dataset.py --help`` (or ``symjax eval --help``) for the options;
``--config paper`` runs the paper's exact search.
"""

from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from symjax.cli.eval_command import main as _main  # noqa: E402


def main(argv: list[str] | None = None) -> int:
    """The same as ``symjax eval``; returns the exit status (0 ok, 2 bad arguments or data)."""
    return _main(sys.argv[1:] if argv is None else argv, prog="eval_dataset.py")


if __name__ == "__main__":
    sys.exit(main())
