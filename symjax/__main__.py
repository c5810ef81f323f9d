"""``python -m symjax ...``: the same as the ``symjax`` console command."""

from symjax.cli import console

console()
