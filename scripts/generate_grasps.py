"""Grasp training data (ACRONYM-keyed HDF5 with partial views): ``symjax generate``.

Run ``python scripts/generate_grasps.py --help`` for the options.
"""

from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from symjax.cli.generate_command import main as _main  # noqa: E402

if __name__ == "__main__":
    sys.exit(_main(sys.argv[1:], prog="generate_grasps.py"))
