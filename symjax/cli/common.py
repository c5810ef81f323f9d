"""What every command shares: ``--config NAME|PATH`` first, then per-field overrides generated
by tyro from the config dataclasses, typed errors as one line and an exit status."""

from __future__ import annotations

import dataclasses
import sys
from collections.abc import Callable, Sequence
from typing import TypeVar

from symjax.errors import SymjaxError

__all__ = ["PresetArgs", "parse", "preset_argument", "run"]

T = TypeVar("T")


@dataclasses.dataclass(frozen=True)
class PresetArgs:
    """The option every command has; a command's own options extend it.

    Attributes:
        config: Preset name (ci, clutter, cycle, default, gpu, kth, paper, study, study_tcp,
            uji: the files in ``configs/``) or the path of a TOML file in the same layout; the
            options below default to its values and override them.
    """

    config: str = "default"


def preset_argument(argv: Sequence[str], default: str = "default") -> str:
    """The value of ``--config`` in ``argv`` (``--config X`` or ``--config=X``), else default."""
    for i, a in enumerate(argv):
        if a == "--config" and i + 1 < len(argv):
            return argv[i + 1]
        if a.startswith("--config="):
            return a.split("=", 1)[1]
    return default


def parse(cls: type[T], argv: Sequence[str], prog: str, description: str | None = None) -> T:
    """Parses ``argv`` into ``cls``, a :class:`PresetArgs` dataclass.

    Without ``--config`` the preset is the default of ``cls``'s own ``config`` field (a job
    with its own preset, such as the grasp cycle's, names it there).

    Fields of ``cls`` named like a preset table (``symmetry``, ``execution``, ...) or
    ``evaluation`` default to the preset's values, so ``--help`` shows what the preset sets.
    """
    import tyro

    from symjax import configs

    own = next(f.default for f in dataclasses.fields(cls) if f.name == "config")
    preset = configs.load(preset_argument(argv, own))
    take = {"evaluation", *configs.SECTIONS}
    values = {f.name: getattr(preset, f.name) for f in dataclasses.fields(cls) if f.name in take}
    default = cls(config=preset.name, **values)
    return tyro.cli(cls, args=list(argv), default=default, prog=prog, description=description)


def run(prog: str, body: Callable[[list[str]], int], argv: Sequence[str] | None = None) -> int:
    """Runs a command body on ``argv`` (default: ``sys.argv[1:]``).

    Returns:
        The body's status; 2 with one line on stderr on a :class:`SymjaxError`, tyro's status
        on ``--help`` or a bad flag, 130 on Ctrl-C.
    """
    from symjax import _interrupt

    argv = sys.argv[1:] if argv is None else list(argv)
    try:
        status = int(body(argv) or 0)
        _interrupt.check()  # an interrupt swallowed on the way still ends the run as one
        return status
    except SymjaxError as e:
        print(f"{prog}: error: {e}", file=sys.stderr)
        return 2
    except SystemExit as e:  # tyro's --help (0) and its argument errors (2)
        return int(e.code or 0) if not isinstance(e.code, str) else 2
    except KeyboardInterrupt:
        print(
            f"{prog}: interrupted; finished results are kept, run again to resume", file=sys.stderr
        )
        return 130
