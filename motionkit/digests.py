"""Hashes of what a piece of work reads (files, configs, motionkit's code, library versions):
the pipeline's stage keys and the per-task keys that let a batch resume."""

from __future__ import annotations

import hashlib
import json
from collections.abc import Iterable
from importlib import metadata
from pathlib import Path
from typing import Any

PACKAGE = Path(__file__).resolve().parent  # the motionkit package folder


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


def source_digest(packages: Iterable[str]) -> str:
    """The hash of motionkit's source files in these subpackages (code changes rerun a stage)."""
    hasher = hashlib.sha256()
    for name in sorted(packages):
        for path in sorted((PACKAGE / name).rglob("*")):
            if path.suffix in (".py", ".toml"):
                hasher.update(str(path.relative_to(PACKAGE)).encode())
                hasher.update(path.read_bytes())
    return hasher.hexdigest()[:16]


def versions(*distributions: str) -> dict[str, str]:
    found = {}
    for name in distributions:
        try:
            found[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            found[name] = "absent"
    return found
