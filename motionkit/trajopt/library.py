"""A flight library: one TOML file that names many solves (trajopt/library.toml).

Each `[[entries]]` table names a base recipe (`recipe`: a recipe name, found beside the library
file, or a path relative to it; none: the built-in defaults), the tables of a recipe to change in
it (`scenario`, `weights`, `contacts`, `jets`, `solver`, `replay`, key by key, and `rate`) and
its targets: `targets` (a list of [x, y, z]) or `grid` (three lists, one per axis, every
combination). Every solve is one clip, named `name` plus its target. IPOPT is quiet
(print_level 0) unless an entry sets `solver.print_level`.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from motionkit.errors import TrajoptError
from motionkit.tomlfile import read_toml
from motionkit.trajopt.config import TrajoptConfig

TABLES = ("scenario", "weights", "contacts", "jets", "solver", "replay")
ENTRY_KEYS = ("name", "recipe", "targets", "grid", "rate", *TABLES)


@dataclass(frozen=True)
class LibrarySolve:
    name: str  # the clip's file stem
    entry: str  # the library entry it comes from
    config: TrajoptConfig


def clip_name(entry: str, target: tuple[float, ...]) -> str:
    return f"{entry}_" + "_".join(f"{v:+.2f}" for v in target).replace(".", "p")


def read_library(path: Path) -> list[LibrarySolve]:
    """Every solve the library names, each config resolved and validated; TrajoptError naming
    the file and the entry on bad input."""
    path = Path(path)
    data = read_toml(path, "flight library", TrajoptError)
    unknown = sorted(set(data) - {"entries"})
    if unknown:
        raise TrajoptError(f"{path}: unknown keys {unknown}; a library has [[entries]] only")
    entries = data.get("entries")
    if not isinstance(entries, list) or not entries:
        raise TrajoptError(f"{path}: expected a non-empty list of [[entries]] tables")
    solves: list[LibrarySolve] = []
    for index, entry in enumerate(entries):
        solves += _entry(entry, index, path)
    seen: set[str] = set()
    for solve in solves:
        if solve.name in seen:
            raise TrajoptError(f"{path}: entry '{solve.entry}': clip '{solve.name}' is named twice")
        seen.add(solve.name)
    return solves


def _entry(entry: Any, index: int, path: Path) -> list[LibrarySolve]:
    where = f"{path}: entries[{index}]"
    if not isinstance(entry, dict):
        raise TrajoptError(f"{where}: expected a table, got {entry!r}")
    name = entry.get("name")
    if not isinstance(name, str) or not name.isidentifier():
        raise TrajoptError(f"{where}: 'name' should be a word (letters, digits, _), got {name!r}")
    where = f"{path}: entry '{name}'"
    unknown = sorted(set(entry) - set(ENTRY_KEYS))
    if unknown:
        raise TrajoptError(f"{where}: unknown keys {unknown}; known: {sorted(ENTRY_KEYS)}")
    base = _recipe(entry.get("recipe"), path, where)
    base.setdefault("solver", {}).setdefault("print_level", 0)
    for key in ("rate", *TABLES):
        if key not in entry:
            continue
        if key != "rate" and not isinstance(entry[key], dict):
            raise TrajoptError(f"{where}: '{key}' should be a table")
        base[key] = entry[key] if key == "rate" else {**base.get(key, {}), **entry[key]}
    solves = []
    for target in _targets(entry, where):
        data = base | {"scenario": {**base.get("scenario", {}), "target": list(target)}}
        config = TrajoptConfig.from_dict(data, where)
        solves.append(LibrarySolve(clip_name(name, target), name, config))
    return solves


def _recipe(recipe: Any, library: Path, where: str) -> dict[str, Any]:
    """The base recipe's tables (an empty dict: the defaults)."""
    if recipe is None:
        return {}
    if not isinstance(recipe, str):
        raise TrajoptError(f"{where}: 'recipe' should be a recipe name or path, got {recipe!r}")
    file = library.parent / (recipe if recipe.endswith(".toml") else f"{recipe}.toml")
    if not file.is_file():
        raise TrajoptError(f"{where}: recipe '{recipe}' not found (no file {file})")
    return read_toml(file, "recipe", TrajoptError)


def _targets(entry: dict[str, Any], where: str) -> list[tuple[float, float, float]]:
    if "targets" in entry and "grid" in entry:
        raise TrajoptError(f"{where}: has both 'targets' and 'grid'; give one")
    if "targets" not in entry and "grid" not in entry:
        raise TrajoptError(f"{where}: no targets: give 'targets' (a list of [x, y, z]) or 'grid'")
    if "targets" in entry:
        targets, field = entry["targets"], "targets"
    else:
        grid, field = entry["grid"], "grid"
        if not (isinstance(grid, list) and len(grid) == 3 and all(_numbers(a) for a in grid)):
            raise TrajoptError(f"{where}: 'grid' should be three lists of numbers, got {grid!r}")
        targets = [list(t) for t in itertools.product(*grid)]
    if not isinstance(targets, list) or not targets:
        raise TrajoptError(f"{where}: '{field}' should be a non-empty list, got {targets!r}")
    for target in targets:
        if not (isinstance(target, list) and len(target) == 3 and _numbers(target)):
            raise TrajoptError(f"{where}: '{field}' should hold [x, y, z] lists, got {target!r}")
    return [(float(x), float(y), float(z)) for x, y, z in targets]


def _numbers(values: Any) -> bool:
    return (
        isinstance(values, list)
        and bool(values)
        and all(isinstance(v, int | float) and not isinstance(v, bool) for v in values)
    )
