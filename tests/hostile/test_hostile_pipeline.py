"""Hostile pipeline state: a stage record in OUT that is damaged (not JSON, not an object,
fields missing or of the wrong type, not text) means the stage runs again, never a traceback."""

from __future__ import annotations

from pathlib import Path

import pytest

from motionkit.pipeline.cache import run_cached

DAMAGED = {
    "not JSON": b"{ this is not json",
    "a list": b"[1, 2]",
    "no key": b'{"seconds": 1.0, "made": "x"}',
    "seconds a string": b'{"key": "k", "seconds": "1", "made": "x"}',
    "not text": b"\xff\xfe\x00",
}


@pytest.mark.parametrize("case", DAMAGED)
def test_a_damaged_stage_record_reruns_the_stage(case: str, tmp_path: Path) -> None:
    calls: list[Path] = []

    def work(folder: Path) -> str:
        calls.append(folder)
        (folder / "made.txt").write_text(str(len(calls)))
        return f"call {len(calls)}"

    out, records = tmp_path / "stage", tmp_path / "records"
    assert run_cached("s", "k", out, records, work).status == "ran"
    (records / "s.json").write_bytes(DAMAGED[case])
    again = run_cached("s", "k", out, records, work)
    assert again.status == "ran" and (out / "made.txt").read_text() == "2"
    assert run_cached("s", "k", out, records, work).status == "cached"  # a sound record again
