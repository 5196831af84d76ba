"""Outputs are all or nothing: written to a temporary file beside the target, then renamed; and
they stay in their folder: only names a folder's manifest lists are replaced, and a name from a
user's file cannot point outside the folder."""

from __future__ import annotations

import contextlib
import json
import math
import os
import re
import tempfile
from collections.abc import Iterable, Iterator
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import IO, Any

from motionkit.core.errors import MotionkitError


@contextlib.contextmanager
def atomic_output(path: Path) -> Iterator[IO[bytes]]:
    """A binary stream that becomes `path` only when the block ends without an exception."""
    path.parent.mkdir(parents=True, exist_ok=True)
    temporary = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    try:
        with open(temporary, "wb") as stream:
            yield stream
        temporary.replace(path)
    finally:
        temporary.unlink(missing_ok=True)


def write_text_atomic(path: Path, text: str) -> None:
    with atomic_output(path) as stream:
        stream.write(text.encode())


def strict_json(value: Any) -> Any:
    """`value` made valid strict JSON: non-finite floats -> None, numpy scalars -> Python."""
    if isinstance(value, dict):
        return {str(k): strict_json(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [strict_json(v) for v in value]
    if hasattr(value, "item") and callable(value.item) and getattr(value, "shape", None) == ():
        value = value.item()
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


def write_json_atomic(path: Path, value: Any) -> None:
    """`value` as indented strict JSON (NaN and infinities as null), all or nothing."""
    write_text_atomic(path, json.dumps(strict_json(value), indent=2, allow_nan=False) + "\n")


# -- output folders -------------------------------------------------------------------------------
# motionkit writes into a folder only the top-level names its manifest lists (recorded before the
# writes): a name the folder holds but the manifest does not is the user's and is never replaced.
MANIFEST = ".motionkit-files.json"
_TEMPORARY = re.compile(r"^\..+\.(\d+)\.tmp$")  # atomic_output's temporary: .NAME.PID.tmp


def inside(folder: Path, name: str, error: type[MotionkitError]) -> Path:
    """`folder / name`, or `error` when that path lies outside `folder` (`../x`, `/x`, a link
    out): names taken from user files never become paths elsewhere."""
    path = Path(folder) / name
    root, target = Path(folder).resolve(), path.resolve()
    if target != root and root not in target.parents:
        raise error(f"{name!r}: would be written outside {folder}; use a plain name")
    return path


@dataclass(frozen=True)
class Manifest:
    """What the manifest of a folder says: the top-level names motionkit wrote there, and beside
    each name a batch wrote (clips, trajopt targets) the key of its task: the hash of what the
    task read, so that `--resume` keeps an output whose key is unchanged."""

    files: frozenset[str] = frozenset()
    keys: dict[str, str] = field(default_factory=dict)  # name -> key

    @classmethod
    def load(cls, folder: Path) -> Manifest:
        """The manifest of `folder`; empty when it has none or it cannot be read (it then
        vouches for nothing)."""
        try:
            data = json.loads((Path(folder) / MANIFEST).read_text())
        except (OSError, ValueError):
            return cls()
        data = data if isinstance(data, dict) else {}
        files = data.get("files") if isinstance(data.get("files"), list) else []
        keys = data.get("keys") if isinstance(data.get("keys"), dict) else {}
        return cls(
            frozenset(n for n in files if isinstance(n, str)),
            {n: k for n, k in keys.items() if isinstance(n, str) and isinstance(k, str)},
        )

    def save(self, folder: Path) -> None:
        """Written into `folder` atomically; the keys of names it does not list are dropped."""
        files = sorted(self.files - {MANIFEST})
        keys = {n: self.keys[n] for n in sorted(self.keys) if n in self.files}
        data: dict[str, Any] = {"files": files, "keys": keys} if keys else {"files": files}
        write_text_atomic(Path(folder) / MANIFEST, json.dumps(data, indent=1) + "\n")


def written_names(folder: Path) -> frozenset[str]:
    """The names the manifest of `folder` lists."""
    return Manifest.load(folder).files


def foreign_entries(folder: Path, names: Iterable[str] | None = None) -> list[str]:
    """The entries of `folder` (of `names` only, if given) that motionkit did not write:
    neither in its manifest nor a leftover temporary of an atomic write."""
    folder = Path(folder)
    if not folder.is_dir():
        return []
    listed = Manifest.load(folder).files
    present = {p.name for p in folder.iterdir()} if names is None else set(names)
    return sorted(
        n
        for n in present
        if n not in listed and n != MANIFEST and not _TEMPORARY.match(n) and (folder / n).exists()
    )


def check_out(folder: Path, names: Iterable[str], error: type[MotionkitError]) -> Path:
    """Refuse up front (before any long work, writing nothing) an output folder that is a file,
    cannot be written, or holds one of `names` (top-level entries to write) that motionkit did
    not write there."""
    folder = Path(folder)
    names = list(names)
    for name in names:
        inside(folder, name, error)
    check_writable(folder, error)
    foreign = foreign_entries(folder, names)
    if foreign:
        raise error(
            f"{folder} holds {', '.join(foreign)}, not written by motionkit; they would be "
            "replaced: move them or choose another --out"
        )
    return folder


def check_writable(folder: Path, error: type[MotionkitError]) -> None:
    """Refuse an output folder that is a file (or lies under one) or cannot be written."""
    folder = Path(folder)
    existing = next(p for p in (folder, *folder.absolute().parents) if p.exists())
    if not existing.is_dir():
        raise error(f"{existing}: is a file, not a folder; give --out a folder")
    try:
        tempfile.TemporaryFile(dir=existing).close()
    except OSError as exc:
        raise error(f"{folder}: cannot write there ({exc.strerror or exc})") from exc


def claim_out(folder: Path, names: Iterable[str], error: type[MotionkitError]) -> Path:
    """`check_out`, then create `folder` and add `names` to its manifest (before they are
    written, so that an interrupted run leaves no file the manifest does not vouch for)."""
    names = set(names)
    check_out(folder, names, error)
    manifest = Manifest.load(folder)
    if not names <= manifest.files:
        replace(manifest, files=manifest.files | names).save(folder)
    return Path(folder)


@contextlib.contextmanager
def claimed_out(folder: Path, names: Iterable[str], error: type[MotionkitError]) -> Iterator[Path]:
    """`claim_out` for a block whose writes may all fail: a folder it made and the block left
    empty (but for the manifest) is removed again."""
    folder = Path(folder)
    made = not folder.exists()
    claim_out(folder, names, error)
    try:
        yield folder
    finally:
        if made and [p.name for p in folder.iterdir()] == [MANIFEST]:
            (folder / MANIFEST).unlink()
            folder.rmdir()


def record_names(folder: Path, names: Iterable[str]) -> None:
    """Write the manifest of `folder`: the top-level names motionkit wrote there (the keys of
    those still listed are kept)."""
    replace(Manifest.load(folder), files=frozenset(names)).save(folder)


def up_to_date(folder: Path, names: Iterable[str], key: str) -> bool:
    """Whether every one of `names` is in `folder`, listed in its manifest with `key`."""
    manifest = Manifest.load(folder)
    return all(
        n in manifest.files and manifest.keys.get(n) == key and (Path(folder) / n).is_file()
        for n in names
    )


def write_files(folder: Path, files: dict[str, bytes], key: str = "") -> None:
    """Write `files` (name -> bytes, in order, each atomically) into `folder`, whose manifest
    lists them already (`claim_out`); then record `key` for them (none if empty). A name is
    forgotten before it is rewritten, so that an interrupt never leaves a new file with an
    old key or an old file with a new key."""
    folder = Path(folder)
    manifest = Manifest.load(folder)
    if any(n in manifest.keys for n in files):
        keys = {n: k for n, k in manifest.keys.items() if n not in files}
        manifest = replace(manifest, keys=keys)
        manifest.save(folder)
    for name, data in files.items():
        with atomic_output(folder / name) as stream:
            stream.write(data)
    if key:
        replace(manifest, keys=manifest.keys | dict.fromkeys(files, key)).save(folder)


def remove_temporaries(folder: Path, pids: Iterable[int]) -> None:
    """Delete the atomic-write temporaries the processes `pids` left in `folder` (and below)
    when they were stopped mid-write."""
    pids = {str(p) for p in pids}
    if not Path(folder).is_dir():
        return
    for path in Path(folder).rglob(".*.tmp"):
        match = _TEMPORARY.match(path.name)
        if match and match[1] in pids:
            path.unlink(missing_ok=True)
