"""TOML input files: reading them, filling frozen config dataclasses from their tables (with
errors of the caller's family) and writing resolved configs back."""

from __future__ import annotations

import re
import tomllib
from dataclasses import MISSING, fields, is_dataclass
from pathlib import Path
from typing import Any, TypeVar, get_args, get_origin, get_type_hints

from motionkit.core.errors import MotionkitError
from motionkit.files.inputs import read_text

T = TypeVar("T")


def read_toml(path: Path, what: str, error: type[MotionkitError]) -> dict[str, Any]:
    """The parsed file, or `error` naming the file and what is wrong with it."""
    text = read_text(path, error, what, empty=True)  # regular files, UTF-8; empty: no keys
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise error(f"{path}: not valid TOML ({exc})") from exc


def load(cls: type[T], data: Any, where: str, error: type[MotionkitError], **given: Any) -> T:
    """The dataclass `cls` filled from a TOML table: a key left out keeps its default, a nested
    dataclass is read from a sub-table (a tuple or dict of them from a list or table of tables),
    a list becomes a tuple, an integer a float where a float is expected. `error` names `where`,
    the [table] and the key of an unknown or missing key, of a value of the wrong type and of one
    the dataclass itself refuses. The fields in `given` are passed as they are, not read."""
    return _table(cls, data, where, "", error, given)


class _Mismatch(Exception):
    """A value is not of the type its field expects."""


def _table(
    cls: type[T],
    data: Any,
    where: str,
    table: str,
    error: type[MotionkitError],
    given: dict[str, Any],
) -> T:
    at = f"{where}: [{table}]" if table else where
    if not isinstance(data, dict):
        raise error(f"{at}: should be a table, got {data!r}")
    known = {f.name: f for f in fields(cls) if f.name not in given}  # type: ignore[arg-type]
    unknown = sorted(set(data) - set(known))
    if unknown:
        raise error(f"{at}: unknown keys {unknown}; known: {sorted(known)}")
    missing = [
        repr(name)
        for name, f in known.items()
        if name not in data and f.default is MISSING and f.default_factory is MISSING
    ]
    if missing:
        raise error(f"{at}: missing {', '.join(missing)}")
    hints = get_type_hints(cls)
    values = {}
    for key, value in data.items():
        try:
            values[key] = _value(
                hints[key], value, where, f"{table}.{key}" if table else key, error
            )
        except _Mismatch:
            expected = _describe(hints[key])
            raise error(f"{at}: '{key}' should be {expected}, got {value!r}") from None
    try:
        return cls(**values, **given)
    except error as exc:  # the dataclass's own checks, located
        raise error(f"{at}: {exc}") from exc


def _value(hint: Any, value: Any, where: str, path: str, error: type[MotionkitError]) -> Any:
    """`value` as the type `hint`; _Mismatch if it is not one."""
    if is_dataclass(hint):
        return _table(hint, value, where, path, error, {})  # type: ignore[arg-type]
    origin, args = get_origin(hint), get_args(hint)
    if origin is tuple:
        if not isinstance(value, list | tuple):
            raise _Mismatch
        kinds = args[:1] * len(value) if args[1:] == (Ellipsis,) else args
        if len(kinds) != len(value):
            raise _Mismatch
        return tuple(
            _value(kind, item, where, f"{path}[{i}]", error)
            for i, (kind, item) in enumerate(zip(kinds, value, strict=True))
        )
    if origin is dict:
        if not isinstance(value, dict):
            raise _Mismatch
        return {
            key: _value(args[1], item, where, f"{path}.{key}", error) for key, item in value.items()
        }
    if hint is Any:
        return value
    if hint is float and isinstance(value, int) and not isinstance(value, bool):
        return float(value)
    if isinstance(value, hint) and isinstance(value, bool) == (hint is bool):
        return value
    raise _Mismatch


def _describe(hint: Any) -> str:
    """How a value of the type `hint` is written in TOML, for messages."""
    if is_dataclass(hint):
        return "a table"
    origin, args = get_origin(hint), get_args(hint)
    if origin is tuple:
        return "[" + ", ".join("..." if a is Ellipsis else _describe(a) for a in args) + "]"
    if origin is dict:
        return f"a table of {_describe(args[1])}"
    return getattr(hint, "__name__", str(hint))


def to_toml(data: dict[str, Any]) -> str:
    """A resolved config (`asdict` of one) as TOML text that `load` reads back."""
    return "\n".join(_toml_lines(data, "")).strip() + "\n"


def _toml_lines(data: dict[str, Any], table: str) -> list[str]:
    """The values of `data` under a [table] header, then each dict among them as a table."""
    values = [
        f"{_key(key)} = {_toml_value(v)}" for key, v in data.items() if not isinstance(v, dict)
    ]
    lines = ["", f"[{table}]", *values] if table and values else values
    for key, value in data.items():
        if isinstance(value, dict):
            lines += _toml_lines(value, f"{table}.{_key(key)}" if table else _key(key))
    return lines


def _key(key: str) -> str:
    """A TOML key: bare where TOML allows it, else quoted."""
    return key if re.fullmatch(r"[A-Za-z0-9_-]+", key) else _toml_value(key)


def _toml_value(value: Any) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, str):
        return '"' + value.replace("\\", "\\\\").replace('"', '\\"') + '"'
    if isinstance(value, list | tuple):
        return "[" + ", ".join(_toml_value(v) for v in value) + "]"
    return repr(value)
