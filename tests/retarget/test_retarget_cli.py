"""`motionkit retarget` and `motionkit mocap fetch` end to end on small files the tests make."""

import json
import re
from pathlib import Path

import pytest
from mocap_synth import TRACKABLE, arms_down, mini_bvh, synth_files
from test_fetch import Server
from test_fetch import server as server  # the loopback server fixture

from motionkit.cli import main
from motionkit.core.errors import RetargetError
from motionkit.dataset import read
from motionkit.retarget.batch import resolve_inputs

pytest.importorskip("placo")


def walk_bvh(path: Path, frames: int = 40) -> Path:
    path.write_text(mini_bvh(arms_down(frames)))
    return path


def files_under(folder: Path) -> list[str]:
    return sorted(str(p.relative_to(folder)) for p in folder.rglob("*")) if folder.exists() else []


def test_retarget_bvh_and_amc_in_parallel(tmp_path: Path, capsys) -> None:
    (tmp_path / "in").mkdir()
    take = synth_files(tmp_path / "in", TRACKABLE)
    walk_bvh(tmp_path / "in" / "walk.bvh")
    take["bvh"].unlink()  # 07_03.amc (+ 07.asf) and walk.bvh: both formats, one folder
    out = tmp_path / "out"
    assert main(["retarget", str(tmp_path / "in"), "--out", str(out), "--jobs", "2"]) == 0
    assert files_under(out) == [
        ".motionkit-files.json", "07_03.mcap", "retarget_summary.json", "walk.mcap"
    ]  # fmt: skip
    summary = json.loads((out / "retarget_summary.json").read_text())
    assert [c["name"] for c in summary["clips"]] == ["07_03", "walk"]
    clip = read(out / "walk.mcap")
    assert len(clip.time) == 40 and clip.metadata.generator == "retarget"
    assert clip.metadata.source.clip == "walk" and clip.metadata.source.licence == ""
    amc = read(out / "07_03.mcap").metadata
    assert amc.source.clip == "07_03" and "CMU" in amc.source.licence  # a CMU-style clip name
    assert set(summary["clips"][1]["stages_s"]) == {
        "read", "targets", "ik", "metrics", "write"
    }  # fmt: skip
    assert clip.metadata.metrics == summary["clips"][1]["metrics"]
    printed = capsys.readouterr().out
    assert "retargeting 2 clip(s)" in printed and "slide p95" in printed


def test_recipe_clips_and_kind(tmp_path: Path, capsys) -> None:
    walk_bvh(tmp_path / "a.bvh")
    recipe = tmp_path / "recipe.toml"
    recipe.write_text('kind = "run"\nclips = ["a.bvh"]\niterations = 3\n')
    out = tmp_path / "out"
    assert main(["retarget", "--config", str(recipe), "--out", str(out), "--kind", "stand"]) == 0
    meta = read(out / "a.mcap").metadata
    assert meta.kind == "stand" and meta.config["iterations"] == 3
    assert meta.config["balance"]["passes"] == 2 and "balance_shift_max_m" in meta.metrics
    assert "cop_inside_share" in meta.metrics["physics"]
    argv = ["retarget", "--config", str(recipe), "--out", str(tmp_path / "plain"), "--no-balance"]
    assert main(argv) == 0
    plain = read(tmp_path / "plain" / "a.mcap").metadata
    assert plain.config["balance"]["passes"] == 0 and "balance_shift_max_m" not in plain.metrics
    assert main(["retarget", "--config", str(recipe), "--out", str(out), "--kind", "amble"]) == 2
    assert "'kind' should be one of 'walk', 'run'" in capsys.readouterr().err


@pytest.mark.parametrize(
    ("name", "break_it", "message"),
    [
        ("truncated.bvh", lambda t: t[: t.rindex("\n", 0, -2)], r"truncated"),
        (
            "channels.bvh",
            lambda t: t.replace("CHANNELS 3", "CHANNELS 4", 1),
            r"line \d+",
        ),
        ("names.bvh", lambda t: t.replace("LeftUpLeg", "Thing1").replace("Left", "Lf"), "Thing1"),
    ],
)
def test_malformed_bvh_exits_nonzero_and_writes_nothing(
    tmp_path: Path, capsys, name: str, break_it, message: str
) -> None:
    path = tmp_path / name
    path.write_text(break_it(mini_bvh(arms_down(12))))
    out = tmp_path / "out"
    code = main(["retarget", str(path), "--out", str(out)])
    err = capsys.readouterr().err
    assert code != 0 and name in err
    assert files_under(out) == []
    assert re.search(message, err), err


def test_amc_frame_missing_a_bone(tmp_path: Path, capsys) -> None:
    take = synth_files(tmp_path)
    lines = take["amc"].read_text().splitlines()
    frame = lines.index("2")
    femur = next(n for n in range(frame, len(lines)) if lines[n].startswith("lfemur "))
    take["amc"].write_text("\n".join(lines[:femur] + lines[femur + 1 :]) + "\n")
    out = tmp_path / "out"
    assert main(["retarget", str(take["amc"]), "--out", str(out)]) == 1
    err = capsys.readouterr().err
    assert "bone 'lfemur' missing" in err and f"line {frame + 1}" in err
    assert files_under(out) == []


def test_one_bad_clip_among_good_ones(tmp_path: Path, capsys) -> None:
    good = walk_bvh(tmp_path / "good.bvh", 12)
    bad = tmp_path / "bad.bvh"
    bad.write_text(mini_bvh(arms_down(12)).replace("MOTION", "MOTON"))
    out = tmp_path / "out"
    assert main(["retarget", str(good), str(bad), "--out", str(out)]) == 1
    assert files_under(out) == [".motionkit-files.json", "good.mcap", "retarget_summary.json"]
    assert "1 of 2 clip(s) failed" in capsys.readouterr().out


def test_inputs_are_resolved_and_checked(tmp_path: Path) -> None:
    (tmp_path / "x").mkdir()
    a = walk_bvh(tmp_path / "x" / "a.bvh")
    fetched = []

    def fake_fetch(ids: list[str]) -> list[tuple[Path, Path]]:
        fetched.extend(ids)
        return [(tmp_path / f"{i}.amc", tmp_path / "asf.asf") for i in ids]

    clips = resolve_inputs([str(tmp_path / "x"), str(a), "02_01"], fake_fetch)
    assert [c.path for c in clips] == [a, tmp_path / "02_01.amc"] and fetched == ["02_01"]
    assert clips[1].cmu_clip == "02_01" and clips[1].asf == tmp_path / "asf.asf"
    (tmp_path / "notes.txt").write_text("x")
    with pytest.raises(RetargetError, match="not a mocap file"):
        resolve_inputs([str(tmp_path / "notes.txt")])
    with pytest.raises(RetargetError, match="not a CMU clip id"):
        resolve_inputs(["nothing-here"])
    (tmp_path / "empty").mkdir()
    with pytest.raises(RetargetError, match=r"no \.bvh or \.amc files"):
        resolve_inputs([str(tmp_path / "empty")])


def test_same_output_name_twice_is_refused(tmp_path: Path, capsys) -> None:
    for folder in ("p", "q"):
        (tmp_path / folder).mkdir()
        walk_bvh(tmp_path / folder / "walk.bvh", 12)
    code = main(["retarget", str(tmp_path / "p"), str(tmp_path / "q"), "--out", str(tmp_path)])
    assert code == 2 and "same output file: ['walk']" in capsys.readouterr().err


def test_fetch_then_retarget_by_clip_id(
    server: Server,
    monkeypatch: pytest.MonkeyPatch,
    tmp_path: Path,
    capsys,
) -> None:
    monkeypatch.setenv("MOTIONKIT_CACHE", str(tmp_path / "cache"))
    take = synth_files(tmp_path, TRACKABLE)
    server.files = {
        "/subjects/07/07.asf": take["asf"].read_bytes(),
        "/subjects/07/07_03.amc": take["amc"].read_bytes(),
    }
    assert main(["mocap", "fetch", "7_3", "--base-url", server.base_url]) == 0
    folder = tmp_path / "cache" / "mocap" / "cmu" / "07"
    assert capsys.readouterr().out.split() == [
        "07_03",
        str(folder / "07_03.amc"),
        str(folder / "07.asf"),
    ]
    assert main(["retarget", "07_03", "--out", str(tmp_path / "out")]) == 0  # from the cache
    assert len(server.requests) == 2
    meta = read(tmp_path / "out" / "07_03.mcap").metadata
    assert meta.source.clip == "07_03" and "mocap.cs.cmu.edu" in meta.source.acknowledgement
    assert main(["mocap", "fetch", "07_04", "--base-url", server.base_url]) == 2
    assert "07_04" in capsys.readouterr().err


def test_a_recipe_sets_the_quality_gate(tmp_path: Path, capsys) -> None:
    take = synth_files(tmp_path)  # 6 frames: the feet lag 4.2 cm (the default gate: 3 cm)
    take["bvh"].unlink()
    recipe = tmp_path / "loose.toml"
    recipe.write_text("[quality]\nfeet_error_mean_m = 0.05\n")
    out = tmp_path / "out"
    assert main(["retarget", str(take["amc"]), "--out", str(out), "--no-balance"]) == 1
    assert "feet_error_mean_m 0.04239 > 0.03" in capsys.readouterr().err
    assert files_under(out) == []
    argv = ["retarget", str(take["amc"]), "--out", str(out), "--no-balance", "--config"]
    assert main([*argv, str(recipe)]) == 0
    assert "07_03.mcap" in files_under(out)
    assert "feet_error_mean_m <= 0.05" in capsys.readouterr().out
    recipe.write_text("[quality]\nfeet_error_mean_m = -1\n")
    assert main([*argv, str(recipe)]) == 2
    assert "feet_error_mean_m" in capsys.readouterr().err
