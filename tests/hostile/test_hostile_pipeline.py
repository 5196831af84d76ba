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


@pytest.mark.parametrize("stage", ["retarget", "train"])
def test_a_stage_recipe_that_fails_to_load_is_refused_before_out_is_made(
    stage: str, tmp_path: Path, capsys
) -> None:
    """Each stage's recipe is loaded before OUT is made: a bad one (here an unknown key in the
    retarget or the train recipe) is one line, exit 2, and no OUT at all."""
    from hostile_support import refused

    from motionkit import recipes

    text = recipes.find("pipeline", "tiny_cpu").read_text()
    (tmp_path / "bad.toml").write_text("[not_a_table]\nkey = 1\n")
    named = {"retarget": 'recipe = "sample_walks"', "train": 'recipe = "tiny_cpu"'}[stage]
    assert named in text
    recipe = tmp_path / "pipeline.toml"
    recipe.write_text(text.replace(named, 'recipe = "bad.toml"'))
    out = tmp_path / "out"
    refused(["pipeline", "--config", str(recipe), "--out", str(out)], capsys, 2,
            rf"stage {stage}: .*bad\.toml", "not_a_table")  # fmt: skip
    assert not out.exists()
