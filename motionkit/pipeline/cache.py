"""Stage caching: a stage's key is the hash of everything it reads (input files, resolved
config, the keys of the stages before it, its source code and main libraries); a stage whose
key and output are unchanged is not run again, and one that runs replaces its output only when
it succeeds."""

from __future__ import annotations

import json
import shutil
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

from motionkit.core.errors import PipelineError
from motionkit.files.outputs import foreign_entries, record_names, write_text_atomic

__all__ = ["STAGING", "Outcome", "run_cached"]

STAGING = ".staging"  # OUT/.staging/NAME: a stage's folder while it runs


@dataclass(frozen=True)
class Outcome:
    """What a stage did: 'ran' or 'cached', how long it took when it ran, what it made."""

    stage: str
    status: str
    seconds: float
    made: str
    output: str
    key: str

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)


def run_cached(
    stage: str,
    key: str,
    output: Path,
    records: Path,
    work: Callable[[Path], str],
    force: bool = False,
) -> Outcome:
    """Run `work(FOLDER)` unless OUTPUT exists from a run with the same key; `work` returns
    the line saying what it made. It writes into a staging folder (OUT/.staging/NAME) that
    replaces OUTPUT only when it succeeds: a failed or interrupted stage leaves the previous
    output and its record as they were. An OUTPUT holding files motionkit did not write there
    is refused before the work."""
    record_path = records / f"{stage}.json"
    record = None if force or not output.exists() else _record(record_path)
    if record is not None and record["key"] == key:
        return Outcome(stage, "cached", record["seconds"], record["made"], str(output), key)
    foreign = foreign_entries(output)
    if foreign:
        raise PipelineError(
            f"{output} holds {', '.join(foreign)}, not written by motionkit; the stage would "
            "replace the folder: move them or choose another --out"
        )
    staging = output.parent / STAGING / output.name
    shutil.rmtree(staging, ignore_errors=True)  # what an interrupted run left
    staging.mkdir(parents=True)
    start = time.perf_counter()
    try:
        made = work(staging)
        record_names(staging, (p.name for p in staging.iterdir()))
    except BaseException:
        shutil.rmtree(staging, ignore_errors=True)
        raise
    record_path.unlink(missing_ok=True)  # no record vouches for a folder being swapped
    _swap(staging, output)
    outcome = Outcome(stage, "ran", round(time.perf_counter() - start, 1), made, str(output), key)
    write_text_atomic(record_path, json.dumps(outcome.to_dict(), indent=2) + "\n")
    return outcome


def _record(path: Path) -> dict[str, Any] | None:
    """A stage's record, or None where there is none or it is unreadable or damaged (then the
    stage runs again, as for a new key)."""
    try:
        record = json.loads(path.read_text())
    except (OSError, UnicodeDecodeError, ValueError):
        return None
    fields = {"key": str, "seconds": (int, float), "made": str}
    if not isinstance(record, dict):
        return None
    if not all(isinstance(record.get(k), kind) for k, kind in fields.items()):
        return None
    return record


def _swap(staging: Path, output: Path) -> None:
    """Put `staging` in the place of `output` (two renames; the old output back if the second
    one does not happen), then delete the old output."""
    old = staging.with_name(f"{staging.name}.old")
    shutil.rmtree(old, ignore_errors=True)
    if output.exists():
        output.rename(old)
    try:
        staging.rename(output)
    except BaseException:
        if old.exists() and not output.exists():
            old.rename(output)
        raise
    shutil.rmtree(old, ignore_errors=True)
