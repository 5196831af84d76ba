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
from dataclasses import dataclass, fields, replace
from pathlib import Path
from typing import Any

from motionkit.core.checks import check, refusal
from motionkit.core.errors import TrajoptError
from motionkit.core.tomlfile import load, read_toml
from motionkit.trajopt.config import TrajoptConfig


@dataclass(frozen=True)
class LibrarySolve:
    name: str  # the clip's file stem
    entry: str  # the library entry it comes from
    config: TrajoptConfig


@dataclass(frozen=True)
class Entry:
    """The keys of an [[entries]] table that are not a recipe's."""

    name: str
    recipe: str = ""  # none: the built-in defaults
    targets: tuple[tuple[float, float, float], ...] = ()
    grid: tuple[tuple[float, ...], tuple[float, ...], tuple[float, ...]] = ((), (), ())

    def __post_init__(self) -> None:
        if not self.name.isidentifier():
            raise refusal(TrajoptError, "name", "a word (letters, digits, _)", self.name)
        if bool(self.targets) == any(self.grid):
            raise TrajoptError("give either 'targets' (a list of [x, y, z]) or 'grid'")
        if any(self.grid) and not all(self.grid):
            raise refusal(TrajoptError, "grid", "three non-empty lists, one per axis", self.grid)
        check(self, TrajoptError, "finite", "targets", "grid")

    @property
    def points(self) -> list[tuple[float, ...]]:
        return list(self.targets or itertools.product(*self.grid))


ENTRY_KEYS = {item.name for item in fields(Entry)}
KNOWN = sorted(ENTRY_KEYS | {item.name for item in fields(TrajoptConfig)})  # those of a recipe
QUIET = {"solver": {"print_level": 0}}  # unless the recipe or the entry sets it


def clip_name(entry: str, target: tuple[float, ...]) -> str:
    return f"{entry}_" + "_".join(f"{v:+.2f}" for v in target).replace(".", "p")


def read_library(path: Path) -> list[LibrarySolve]:
    """Every solve the library names, each config resolved and validated.

    TrajoptError naming the file and the entry on bad input.

    Args:
        path: the library's TOML file ([[entries]] tables; recipes are found beside it).

    Returns:
        One LibrarySolve per clip (name, entry, config), entry by entry, target by target.

    Raises:
        TrajoptError: a file that cannot be read, keys other than [[entries]], an entry with
            unknown keys, a bad name, targets or grid, a missing recipe, an invalid config, or
            a clip named twice.
    """
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


def _entry(table: Any, index: int, path: Path) -> list[LibrarySolve]:
    named = isinstance(table, dict) and isinstance(table.get("name"), str)
    where = f"{path}: entry '{table['name']}'" if named else f"{path}: entries[{index}]"
    if not isinstance(table, dict):
        raise TrajoptError(f"{where}: should be a table, got {table!r}")
    unknown = sorted(set(table) - set(KNOWN))
    if unknown:
        raise TrajoptError(f"{where}: unknown keys {unknown}; known: {KNOWN}")
    entry = load(Entry, {k: v for k, v in table.items() if k in ENTRY_KEYS}, where, TrajoptError)
    changes = {k: v for k, v in table.items() if k not in ENTRY_KEYS}
    data = _merge(_merge(QUIET, _recipe(entry.recipe, path, where)), changes)
    config = TrajoptConfig.from_dict(data, where)
    return [
        LibrarySolve(
            clip_name(entry.name, target),
            entry.name,
            replace(config, scenario=replace(config.scenario, target=target)),
        )
        for target in entry.points
    ]


def _merge(base: dict[str, Any], changes: dict[str, Any]) -> dict[str, Any]:
    """`base` with the tables of `changes` merged into its own key by key, its other keys
    replaced."""
    return base | {
        key: base[key] | value
        if isinstance(value, dict) and isinstance(base.get(key), dict)
        else value
        for key, value in changes.items()
    }


def _recipe(recipe: str, library: Path, where: str) -> dict[str, Any]:
    """The base recipe's tables (an empty dict: the defaults)."""
    if not recipe:
        return {}
    file = library.parent / (recipe if recipe.endswith(".toml") else f"{recipe}.toml")
    if not file.is_file():
        raise TrajoptError(f"{where}: recipe '{recipe}' not found (no file {file})")
    return read_toml(file, "recipe", TrajoptError)
