"""Type checks of config dataclass fields, shared by the configs and the TOML loader.

Every value is checked against the field's type annotation (``bool``, ``int``, ``float``,
``str``, ``Literal[...]``, ``tuple[...]``, ``X | None``, nested dataclasses): floats must be
finite, ints may not be bools or floats. :func:`check_fields` runs first in every config's
``__post_init__``, before its range checks, so NaN never reaches a comparison; :func:`build`
fills a config from a TOML table, where ``"none"`` stands for None.
"""

from __future__ import annotations

import dataclasses
import math
import types
import typing
from typing import Any

from symjax.errors import ConfigError

__all__ = ["build", "check_fields", "describe"]


def describe(hint: Any) -> str:
    """A reader's name for a type annotation (for messages)."""
    origin, args = typing.get_origin(hint), typing.get_args(hint)
    if origin is typing.Literal:
        return "one of " + ", ".join(repr(a) for a in args)
    if origin in (typing.Union, types.UnionType):
        return " or ".join("none" if a is type(None) else describe(a) for a in args)
    if origin is tuple:
        if len(args) == 2 and args[1] is Ellipsis:
            return f"a list of {describe(args[0])}"
        return f"a list of {len(args)} values ({', '.join(describe(a) for a in args)})"
    if dataclasses.is_dataclass(hint):
        return f"a table of {hint.__name__} fields"
    return {
        bool: "true or false",
        int: "an integer",
        float: "a finite number",
        str: "a string",
    }.get(hint, str(hint))


def _coerce(hint: Any, value: Any, where: str) -> Any:
    origin, args = typing.get_origin(hint), typing.get_args(hint)

    def bad() -> ConfigError:
        return ConfigError(f"{where} = {value!r} is not valid; expected {describe(hint)}")

    if origin in (typing.Union, types.UnionType):
        if type(None) in args and (value is None or value == "none"):
            return None
        for a in args:
            if a is type(None):
                continue
            try:
                return _coerce(a, value, where)
            except ConfigError:
                continue
        raise bad()
    if origin is typing.Literal:
        if value in args and type(value) is type(next(a for a in args if a == value)):
            return value
        raise bad()
    if origin is tuple:
        if not isinstance(value, list | tuple):
            raise bad()
        if len(args) == 2 and args[1] is Ellipsis:
            return tuple(_coerce(args[0], v, f"{where}[{i}]") for i, v in enumerate(value))
        if len(value) != len(args):
            raise bad()
        return tuple(
            _coerce(a, v, f"{where}[{i}]") for i, (a, v) in enumerate(zip(args, value, strict=True))
        )
    if dataclasses.is_dataclass(hint):
        if dataclasses.is_dataclass(value) and isinstance(value, hint):
            return value
        if not isinstance(value, dict):
            raise bad()
        return build(hint, value, where)
    if hint is bool:
        if isinstance(value, bool):
            return value
        raise bad()
    if hint is int:
        if isinstance(value, int) and not isinstance(value, bool):
            return value
        raise bad()
    if hint is float:
        if isinstance(value, int | float) and not isinstance(value, bool):
            if not math.isfinite(value):
                raise ConfigError(f"{where} = {value!r} must be finite")
            return float(value)
        raise bad()
    if hint is str:
        if isinstance(value, str):
            return value
        raise bad()
    raise ConfigError(f"{where}: unsupported field type {hint!r}")


def build(cls: type, table: dict[str, Any], where: str, base: Any = None):
    """A ``cls`` instance from a TOML table, on top of ``base`` (default: ``cls()``).

    Args:
        cls: A frozen config dataclass.
        table: Key -> value; nested dataclass fields take sub-tables.
        where: Where the table came from (``"paper.toml [symmetry]"``), for messages.
        base: The instance whose values are kept for keys the table does not set.

    Raises:
        ConfigError: Unknown key, wrong type, or a value the dataclass rejects; the message
            names the key, the value and what is accepted.
    """
    hints = _hints(cls)
    names = [f.name for f in dataclasses.fields(cls) if f.init]
    values: dict[str, Any] = {}
    for key, value in table.items():
        if key not in names:
            raise ConfigError(
                f"{where}: unknown key {key!r} = {value!r}; expected one of: {', '.join(names)}"
            )
        sub_base = getattr(base, key) if base is not None else None
        hint = hints[key]
        if dataclasses.is_dataclass(hint) and isinstance(value, dict):
            values[key] = build(hint, value, f"{where}.{key}", sub_base)
        else:
            values[key] = _coerce(hint, value, f"{where}: {key}")
    try:
        return dataclasses.replace(base, **values) if base is not None else cls(**values)
    except ConfigError as e:
        raise ConfigError(f"{where}: {e}") from None
    except (TypeError, ValueError) as e:
        raise ConfigError(f"{where}: {e}") from None


def check_fields(obj: Any) -> None:
    """Checks every field of a config dataclass instance against its annotation.

    Raises:
        ConfigError: ``<Class>.<field> = <value> is not valid; expected <type>``.
    """
    cls = type(obj)
    hints = _hints(cls)
    for f in dataclasses.fields(cls):
        value = getattr(obj, f.name)
        if dataclasses.is_dataclass(value) and isinstance(value, hints[f.name]):
            continue  # checked when it was built
        _coerce(hints[f.name], value, f"{cls.__name__}.{f.name}")


_HINTS: dict[type, dict[str, Any]] = {}


def _hints(cls: type) -> dict[str, Any]:
    if cls not in _HINTS:
        _HINTS[cls] = typing.get_type_hints(cls)
    return _HINTS[cls]
