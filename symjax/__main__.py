"""``python -m symjax ...``: the same as the ``symjax`` console command."""

import sys

from symjax.cli import main

sys.exit(main())
