"""Hashes of what a piece of work reads (files, configs, motionkit's code, library versions):
the pipeline's stage keys and the per-task keys that let a batch resume."""

from __future__ import annotations

import ast
import hashlib
import json
from importlib import metadata
from pathlib import Path
from typing import Any

PACKAGE = Path(__file__).resolve().parents[1]  # the motionkit package folder


def digest(*parts: Any) -> str:
    """A short hash of JSON-serialisable parts (paths and other objects as their str)."""
    text = json.dumps(parts, sort_keys=True, default=str)
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def file_digest(path: Path) -> str:
    hasher = hashlib.sha256()
    with open(path, "rb") as stream:
        for block in iter(lambda: stream.read(1 << 20), b""):
            hasher.update(block)
    return hasher.hexdigest()


def code_digest(*modules: str, root: Path | None = None) -> str:
    """The hash of the code a piece of work runs: the source of these motionkit modules (dotted
    names, e.g. "motionkit.trajopt.runner"), of every motionkit module they import, directly or
    through others, and of the data files (.toml) beside them. `root` is the motionkit package
    folder (default PACKAGE). A change to any of them changes the hash; one elsewhere does not."""
    root = PACKAGE if root is None else root
    hasher = hashlib.sha256()
    for path in sorted(import_closure(modules, root)):
        hasher.update(str(path.relative_to(root)).encode())
        hasher.update(path.read_bytes())
    return hasher.hexdigest()[:16]


_closures: dict[tuple[tuple[str, ...], Path], tuple[frozenset[Path], tuple]] = {}


def import_closure(modules: tuple[str, ...], root: Path = PACKAGE) -> frozenset[Path]:
    """The files of `modules` and of the motionkit modules they import, transitively (imports
    inside functions, the packages' __init__ files and the submodules a package's _LAZY table
    loads on first use), with the .toml files in their folders. Kept while no file changes."""
    key = (tuple(modules), root)
    if key in _closures:
        files, stamps = _closures[key]
        if _stamps(files) == stamps:
            return files
    found: set[Path] = set()
    pending = list(modules)
    while pending:
        path = _module_file(pending.pop(), root)
        if path is None or path in found:
            continue
        found.add(path)
        pending += _imports(path, root)
    folders = {path.parent for path in found}
    files = frozenset(found | {p for folder in folders for p in folder.glob("*.toml")})
    _closures[key] = (files, _stamps(files))
    return files


def _stamps(files: frozenset[Path]) -> tuple:
    stats = ((path, path.stat()) for path in sorted(files) if path.exists())
    return tuple((path, s.st_mtime_ns, s.st_size) for path, s in stats)


def _module_file(name: str, root: Path) -> Path | None:
    """motionkit/a/b.py or motionkit/a/b/__init__.py of "motionkit.a.b" (None if neither)."""
    parts = name.split(".")
    if parts[0] != root.name:
        return None
    base = root.joinpath(*parts[1:])
    for path in (base.with_suffix(".py"), base / "__init__.py"):
        if path.is_file():
            return path
    return None


def _imports(path: Path, root: Path) -> list[str]:
    """The modules a file names: its imports (with the packages above them), the submodules a
    `from package import name` may mean, and a package's _LAZY submodules."""
    relative = path.relative_to(root.parent).with_suffix("")
    package = relative.parts[:-1]  # the package a relative import starts from
    names: list[str] = []
    tree = ast.parse(path.read_bytes(), filename=str(path))
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            names += [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                anchor = package[: len(package) - node.level + 1]
                base = ".".join([*anchor, *([base] if base else [])])
            names += [base, *(f"{base}.{alias.name}" for alias in node.names)]
        elif path.name == "__init__.py" and _is_lazy_table(node):
            names += [f"{'.'.join(package)}.{m}" for m in _lazy_modules(node.value)]
    parents = [".".join(n.split(".")[:i]) for n in names for i in range(1, n.count(".") + 1)]
    return [n for n in names + parents if n.split(".")[0] == root.name]


def _is_lazy_table(node: ast.AST) -> bool:
    return (
        isinstance(node, ast.Assign)
        and any(isinstance(t, ast.Name) and t.id == "_LAZY" for t in node.targets)
        and isinstance(node.value, ast.Dict)
    )


def _lazy_modules(table: ast.Dict) -> list[str]:
    """The submodule of each _LAZY entry: a "module" value or the first of ("module", name)."""
    modules = []
    for value in table.values:
        if isinstance(value, ast.Tuple) and value.elts:
            value = value.elts[0]
        if isinstance(value, ast.Constant) and isinstance(value.value, str):
            modules.append(value.value)
    return modules


def versions(*distributions: str) -> dict[str, str]:
    found = {}
    for name in distributions:
        try:
            found[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            found[name] = "absent"
    return found
