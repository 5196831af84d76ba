"""`motionkit retarget --resume` in local processes: clips whose outputs are up to date (same
input file, config, robot and code) are kept, the rest retargeted; an output of another config
or input is not up to date."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from mocap_synth import arms_down, mini_bvh

from motionkit.cli import main

pytest.importorskip("placo")


def stamps(out: Path) -> dict[str, int]:
    return {p.stem: p.stat().st_mtime_ns for p in sorted(out.glob("*.mcap"))}


def test_resume_retargets_only_what_is_missing_or_changed(tmp_path: Path, capsys) -> None:
    walks = tmp_path / "walks"
    walks.mkdir()
    for i, name in enumerate(("a", "b", "c")):
        (walks / f"{name}.bvh").write_text(mini_bvh(arms_down(20 + 5 * i)))
    out = tmp_path / "out"
    argv = ["retarget", str(walks), "--out", str(out), "--no-balance"]
    assert main(argv) == 0
    first = {p.stem: p.read_bytes() for p in out.glob("*.mcap")}
    (out / "b.mcap").unlink()  # the sweep stopped before b
    (walks / "c.bvh").write_text(mini_bvh(arms_down(26)))  # c's input changed
    before = stamps(out)
    capsys.readouterr()
    assert main([*argv, "--jobs", "2", "--resume"]) == 0
    printed = capsys.readouterr().out
    assert "a: up to date, kept" in printed
    assert printed.count("up to date, kept ->") == 1 and printed.count(" frames in ") == 2
    assert "b: 25 frames in" in printed and "c: 26 frames in" in printed
    after = stamps(out)
    assert after["a"] == before["a"] and after["c"] != before["c"]
    assert (out / "b.mcap").read_bytes() == first["b"]  # made again, the same
    summary = json.loads((out / "retarget_summary.json").read_text())
    assert [c["resumed"] for c in summary["clips"]] == [True, False, False]
    assert [c["frames"] for c in summary["clips"]] == [20, 25, 26]

    capsys.readouterr()  # another config: nothing is up to date
    assert main(["retarget", str(walks), "--out", str(out), "--resume"]) == 0
    assert "up to date" not in capsys.readouterr().out
