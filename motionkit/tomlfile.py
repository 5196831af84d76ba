"""TOML input files: reading them, and filling frozen config dataclasses from their tables,
with errors of the caller's family."""

from __future__ import annotations

import tomllib
from dataclasses import fields, replace
from pathlib import Path
from typing import Any

from motionkit.errors import MotionkitError


def read_toml(path: Path, what: str, error: type[MotionkitError]) -> dict[str, Any]:
    """The parsed file, or `error` naming the file and what is wrong with it."""
    try:
        return tomllib.loads(Path(path).read_text())
    except OSError as exc:
        raise error(f"{path}: cannot read {what} ({exc.strerror})") from exc
    except tomllib.TOMLDecodeError as exc:
        raise error(f"{path}: not valid TOML ({exc})") from exc


def build_dataclass(
    cls: type, values: dict[str, Any], where: str, error: type[MotionkitError]
) -> Any:
    """`cls()` with `values` replacing its defaults, each checked against the default's type
    (TOML lists become tuples, integers become floats where a float is expected); `error`
    names `where`, the key and what was expected."""
    known = {f.name for f in fields(cls)}
    unknown = sorted(set(values) - known)
    if unknown:
        raise error(f"{where}: unknown keys {unknown}; known: {sorted(known)}")
    default = cls()
    converted = {}
    for key, value in values.items():
        expected = getattr(default, key)
        if isinstance(expected, tuple) and isinstance(value, list):
            value = tuple(float(v) if _is_int(v) and _floats(expected) else v for v in value)
        elif isinstance(expected, float) and _is_int(value):
            value = float(value)
        if not isinstance(value, type(expected)) or isinstance(value, bool) != isinstance(
            expected, bool
        ):
            raise error(f"{where}: '{key}' should be {type(expected).__name__}, got {value!r}")
        converted[key] = value
    try:
        return replace(default, **converted)
    except error as exc:  # the dataclass's own checks, located
        raise error(f"{where}: {exc}") from exc


def build_tables(
    data: dict[str, Any],
    tables: dict[str, type],
    where: str,
    error: type[MotionkitError],
    others: tuple[str, ...] = (),
) -> dict[str, Any]:
    """One dataclass per [table] of a recipe (`build_dataclass`; a table left out keeps its
    defaults); a table that is neither in `tables` nor in `others` is refused."""
    unknown = sorted(set(data) - set(tables) - set(others))
    if unknown:
        known = sorted([*tables, *others])
        raise error(f"{where}: unknown tables {unknown}; known: {known}")
    values = {}
    for name, kind in tables.items():
        table = data.get(name, {})
        if not isinstance(table, dict):
            raise error(f"{where}: '{name}' should be a table [{name}]")
        values[name] = build_dataclass(kind, table, f"{where}: [{name}]", error)
    return values


def _is_int(value: object) -> bool:
    return isinstance(value, int) and not isinstance(value, bool)


def _floats(default: tuple) -> bool:
    return bool(default) and all(isinstance(v, float) for v in default)
