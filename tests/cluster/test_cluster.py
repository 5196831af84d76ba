"""Retarget and trajopt batches on a real local Ray cluster (ray_head.py) give the files local
processes give; a task whose worker dies is run again, and lost after a second death; --resume
solves only what is missing; the trajopt workers use the derivatives the driver compiled."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from mocap_synth import arms_down, mini_bvh

from motionkit.cli import main
from motionkit.dataset import read
from motionkit.files.outputs import MANIFEST

pytest.importorskip("ray")
pytest.importorskip("placo")
import ray_head  # the fixtures (a conftest.py here would shadow the root one)

ray_cluster, worker_cache = ray_head.ray_cluster, ray_head.worker_cache
_quick_compile = ray_head._quick_compile  # autouse
REPO = Path(__file__).resolve().parents[2]
RECIPES = REPO / "motionkit" / "recipes" / "trajopt"
CLIPS = ("walk0", "walk1", "walk2")
TARGETS = ("takeoff_+0p00_+0p00_+0p80", "takeoff_+0p00_+0p00_+1p00")
ARRAYS = ("time", "base_position", "base_orientation", "joint_positions", "joint_velocities")


@pytest.fixture(scope="module")
def walks(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Three short synthetic walks (30, 35 and 40 frames)."""
    folder = tmp_path_factory.mktemp("walks")
    for i, name in enumerate(CLIPS):
        (folder / f"{name}.bvh").write_text(mini_bvh(arms_down(30 + 5 * i)))
    return folder


@pytest.fixture(scope="module")
def local_walks(walks: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The walks retargeted by two local processes: the reference."""
    out = tmp_path_factory.mktemp("local") / "out"
    assert main(["retarget", str(walks), "--out", str(out), "--jobs", "2"]) == 0
    return out


def clip_bytes(out: Path) -> dict[str, bytes]:
    return {path.stem: path.read_bytes() for path in sorted(out.glob("*.mcap"))}


def table(printed: str) -> list[str]:
    """The quality table's rows (the same for the same clips)."""
    return [line for line in printed.splitlines() if line.startswith(CLIPS)]


def test_retarget_on_the_cluster_is_bit_identical_to_local_processes(
    ray_cluster: Any, walks: Path, local_walks: Path, tmp_path: Path, capsys
) -> None:
    capsys.readouterr()
    main(["retarget", str(walks), "--out", str(local_walks), "--jobs", "2"])
    local_table = table(capsys.readouterr().out)
    out = tmp_path / "out"
    assert main(["retarget", str(walks), "--out", str(out), "--cluster", ray_cluster.address]) == 0
    printed = capsys.readouterr().out
    assert f"with the Ray cluster at {ray_cluster.address} (2 CPUs)" in printed
    assert sorted(p.name for p in out.iterdir()) == sorted(p.name for p in local_walks.iterdir())
    assert clip_bytes(out) == clip_bytes(local_walks) and len(clip_bytes(out)) == 3
    for name in CLIPS:
        ours, theirs = read(out / f"{name}.mcap"), read(local_walks / f"{name}.mcap")
        for field in ARRAYS:
            assert np.array_equal(getattr(ours, field), getattr(theirs, field)), field
    assert table(printed) == local_table and len(local_table) == 3
    summary = json.loads((out / "retarget_summary.json").read_text())
    reference = json.loads((local_walks / "retarget_summary.json").read_text())
    assert [c["metrics"] for c in summary["clips"]] == [c["metrics"] for c in reference["clips"]]


def test_a_killed_worker_is_retried_through_the_client_address(
    ray_cluster: Any, walks: Path, local_walks: Path, tmp_path: Path, monkeypatch, capsys
) -> None:
    """walk1's first worker dies mid-task (os._exit); Ray runs it again; same files."""
    marks = tmp_path / "marks"
    marks.mkdir()
    monkeypatch.setenv("MOTIONKIT_TEST_KILL", f"{marks},walk1,1")
    out = tmp_path / "out"
    assert main(["retarget", str(walks), "--out", str(out), "--cluster", ray_cluster.client]) == 0
    assert sorted(p.name for p in marks.iterdir()) == ["walk1.1"]  # it died once
    assert clip_bytes(out) == clip_bytes(local_walks)
    assert "failed" not in capsys.readouterr().err


def test_a_task_whose_worker_dies_twice_is_reported_failed(
    ray_cluster: Any, walks: Path, local_walks: Path, tmp_path: Path, monkeypatch, capsys
) -> None:
    marks = tmp_path / "marks"
    marks.mkdir()
    monkeypatch.setenv("MOTIONKIT_TEST_KILL", f"{marks},walk2,2")
    out = tmp_path / "out"
    assert main(["retarget", str(walks), "--out", str(out), "--cluster", ray_cluster.address]) == 1
    assert sorted(p.name for p in marks.iterdir()) == ["walk2.1", "walk2.2"]
    captured = capsys.readouterr()
    assert "walk2: failed: its Ray worker died (2 attempts)" in captured.err
    assert "1 of 3 clip(s) failed; nothing written for them" in captured.out
    assert clip_bytes(out) == {k: v for k, v in clip_bytes(local_walks).items() if k != "walk2"}
    summary = json.loads((out / "retarget_summary.json").read_text())
    assert [c["output"] for c in summary["clips"]] == ["walk0.mcap", "walk1.mcap", None]


def test_resume_on_the_cluster_retargets_only_what_is_missing(
    ray_cluster: Any, walks: Path, local_walks: Path, tmp_path: Path, capsys
) -> None:
    out = tmp_path / "out"
    assert main(["retarget", str(walks), "--out", str(out), "--jobs", "2"]) == 0
    (out / "walk1.mcap").unlink()  # as if the sweep had stopped before walk1
    kept = {n: (out / f"{n}.mcap").stat().st_mtime_ns for n in ("walk0", "walk2")}
    capsys.readouterr()
    argv = ["retarget", str(walks), "--out", str(out), "--cluster", ray_cluster.address]
    assert main([*argv, "--resume"]) == 0
    printed = capsys.readouterr().out
    assert printed.count("up to date, kept") == 2 and printed.count(" frames in ") == 1
    assert "walk1: 35 frames in" in printed
    assert "2 of 3 clip(s) up to date and kept (--resume)" in printed
    assert {n: (out / f"{n}.mcap").stat().st_mtime_ns for n in kept} == kept
    assert clip_bytes(out) == clip_bytes(local_walks)
    summary = json.loads((out / "retarget_summary.json").read_text())
    assert [c["resumed"] for c in summary["clips"]] == [True, False, True]
    reference = json.loads((local_walks / "retarget_summary.json").read_text())
    assert [c["metrics"] for c in summary["clips"]] == [c["metrics"] for c in reference["clips"]]


def test_an_unreachable_cluster_is_one_line_and_writes_nothing(
    walks: Path, tmp_path: Path, capsys
) -> None:
    out = tmp_path / "out"
    assert main(["retarget", str(walks), "--out", str(out), "--cluster", "127.0.0.1:1"]) == 2
    err = capsys.readouterr().err
    assert err == "motionkit: error: --cluster 127.0.0.1:1: no Ray cluster answers there " \
        "(Connection refused)\n"  # fmt: skip
    assert not out.exists()


def test_ctrl_c_on_the_cluster_keeps_the_finished_clips_whole(
    ray_cluster: Any, tmp_path: Path
) -> None:
    """SIGINT after the first clip: status 130 at once, the clips written so far whole and
    listed, no temporary file, no summary."""
    walks = tmp_path / "walks"
    walks.mkdir()
    for k in range(6):  # 2 CPUs: after the first clip, at least three have not started
        (walks / f"long{k}.bvh").write_text(mini_bvh(arms_down(300 + 10 * k)))
    out = tmp_path / "out"
    # unbuffered: the "[1/4]" line must arrive when the first clip is written, not at exit
    env = os.environ | {"PYTHONPATH": str(REPO), "PYTHONUNBUFFERED": "1"}
    argv = ["retarget", str(walks), "--out", str(out), "--cluster", ray_cluster.address]
    command = [sys.executable, "-m", "motionkit.cli", *argv]
    process = subprocess.Popen(
        command, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
        preexec_fn=_ctrl_c_as_in_a_terminal,
    )  # fmt: skip
    assert process.stdout is not None
    sent = False
    for line in process.stdout:  # Ray's worker lines share the stream: "in", not startswith
        if "[1/6]" in line:
            process.send_signal(signal.SIGINT)
            sent = True
            break
    assert sent, "no progress line for the first clip"
    _, err = process.communicate(timeout=60)
    assert process.returncode == 130 and "motionkit: interrupted" in err
    written = sorted(p.name for p in out.iterdir())
    clips = [name for name in written if name.endswith(".mcap")]
    assert written == [MANIFEST, *clips] and 1 <= len(clips) < 6
    for name in clips:
        assert read(out / name).frames >= 300


def _ctrl_c_as_in_a_terminal() -> None:
    """SIGINT at its default in the child: a run started in the background (`cmd &` in a
    script, as CI may be) inherits it ignored, and Python then never raises KeyboardInterrupt."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def grid_argv(recipe: Path, out: Path, *extra: str) -> list[str]:
    return [
        "trajopt", "--scenario", "takeoff", "--config", str(recipe), "--out", str(out),
        "--grid", "0", "0", "0.8,1.0", "--quiet", "--no-replay", *extra,
    ]  # fmt: skip


def knots(out: Path, name: str) -> dict[str, np.ndarray]:
    with np.load(out / f"{name}.knots.npz") as data:
        return {key: data[key] for key in data.files}


def assert_same_solves(ours: Path, theirs: Path, names: tuple[str, ...]) -> None:
    for name in names:
        a, b = knots(ours, name), knots(theirs, name)
        assert sorted(a) == sorted(b)
        for key in a:
            assert np.array_equal(a[key], b[key]), (name, key)
        clip, reference = read(ours / f"{name}.mcap"), read(theirs / f"{name}.mcap")
        for field in (*ARRAYS, "thrust", "contact_forces"):
            assert np.array_equal(getattr(clip, field), getattr(reference, field)), field


@pytest.mark.slow
def test_trajopt_grid_on_the_cluster_matches_local_and_resumes(
    ray_cluster: Any, worker_cache: Path, tmp_path: Path, capsys
) -> None:
    """Two take-offs: local processes and the cluster give the same knots and clips; the
    workers (no C compiler) solve with the libraries the driver compiled and sent; --resume
    after losing one solve's files solves that one only."""
    pytest.importorskip("casadi")
    from motionkit.robot.model import cache_dir

    recipe = tmp_path / "takeoff.toml"
    recipe.write_text((RECIPES / "takeoff.toml").read_text().replace("knots = 20", "knots = 14"))
    local, remote = tmp_path / "local", tmp_path / "remote"
    assert main(grid_argv(recipe, local, "--jobs", "2")) == 0
    capsys.readouterr()
    assert main(grid_argv(recipe, remote, "--cluster", ray_cluster.address)) == 0
    printed = capsys.readouterr().out
    assert "solving 2 clip(s) with the Ray cluster" in printed
    assert "2 of 2 targets solved" in printed
    assert_same_solves(remote, local, TARGETS)
    sent = {p.name: p.read_bytes() for p in (cache_dir() / "trajopt_compiled").glob("*.so")}
    installed = {p.name: p.read_bytes() for p in (worker_cache / "trajopt_compiled").glob("*.so")}
    assert len(installed) == 2 and installed.items() <= sent.items()

    kept = remote / f"{TARGETS[0]}.mcap"
    before = kept.stat().st_mtime_ns
    for suffix in (".mcap", ".knots.npz", ".config.json"):
        (remote / f"{TARGETS[1]}{suffix}").unlink()
    assert main(grid_argv(recipe, remote, "--cluster", ray_cluster.address, "--resume")) == 0
    printed = capsys.readouterr().out
    assert "solving 1 clip(s) with the Ray cluster" in printed and "1 up to date, kept" in printed
    assert f"{TARGETS[0]}: " in printed and printed.count("(up to date, kept)") == 1
    assert kept.stat().st_mtime_ns == before
    assert_same_solves(remote, local, TARGETS)
    manifest = json.loads((remote / MANIFEST).read_text())
    assert sorted(manifest["keys"]) == sorted(
        f"{name}{suffix}" for name in TARGETS for suffix in (".mcap", ".knots.npz", ".config.json")
    )
