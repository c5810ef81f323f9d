"""The paper's grasp cycle (Algorithm 1) on seeded table scenes: ``symjax clear-table``.

Run ``python scripts/clear_table.py --help`` for the options.
"""

from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from symjax.cli.cycle_command import main as _main  # noqa: E402

if __name__ == "__main__":
    sys.exit(_main(sys.argv[1:], prog="clear_table.py"))
