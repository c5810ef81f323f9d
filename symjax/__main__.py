"""``python -m symjax ...``: the same as the ``symjax`` console command."""

from symjax.cli import console

if __name__ == "__main__":  # not when a spawned worker process imports this module
    console()
