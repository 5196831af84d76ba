"""Hostile clips through `motionkit dataset validate|info|export` and `motionkit view`: each is
refused (validate: a FAIL line of its report) with one line naming the file and the problem, no
traceback, the earlier export in the output folder unchanged and no viewer server started.

Every hostile clip is named good.mcap like the good one: had `export` accepted it, it would have
overwritten the good export."""

from __future__ import annotations

import json
import os
import re
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from hostile_support import no_hang, refused, snapshot, tampered
from mcap.writer import Writer

import motionkit.dataset.clip as clip_module
from motionkit.cli import main
from motionkit.dataset import Source, Trajectory, write
from motionkit.dataset.messages import MOTION_SCHEMA, motion_schema
from motionkit.dataset.synthetic import synthetic_trajectory
from motionkit.robot import Robot, ironcub


@pytest.fixture(scope="module")
def robot() -> Robot:
    return ironcub()


@pytest.fixture(scope="module")
def walk(robot: Robot) -> Trajectory:
    return synthetic_trajectory(robot, 1.0, seed=5)


@pytest.fixture(scope="module")
def exported(tmp_path_factory: pytest.TempPathFactory, robot: Robot, walk: Trajectory) -> Path:
    """A folder holding the good clip's npz export."""
    folder = tmp_path_factory.mktemp("good")
    good = write(folder / "good.mcap", walk, robot)
    out = folder / "out"
    assert main(["dataset", "validate", str(good)]) == 0
    assert main(["dataset", "export", str(good), "--format", "npz", "--out", str(out)]) == 0
    assert list(snapshot(out)) == ["good.npz"]
    return out


def _edited(path: Path, robot: Robot, walk: Trajectory, field: str, frames: slice, value) -> Path:
    values = np.array(getattr(walk, field))
    values[frames] = value
    return write(path, replace(walk, **{field: values}), robot)


def _no_messages(path: Path, robot: Robot, walk: Trajectory) -> Path:
    """A well-formed MCAP with the schema, channel and metadata of a clip but no message."""
    with open(path, "wb") as stream:
        writer = Writer(stream)
        writer.start()
        schema = writer.register_schema(MOTION_SCHEMA, "protobuf", motion_schema())
        writer.register_channel("/motion", "protobuf", schema)
        writer.add_metadata("motionkit", clip_module._metadata_record(walk))
        writer.finish()
    return path


def _garbage_payload(path: Path, robot: Robot, walk: Trajectory) -> Path:
    """A well-formed MCAP (CRCs valid) whose one /motion message is not a MotionChunk."""
    with open(path, "wb") as stream:
        writer = Writer(stream)
        writer.start()
        schema = writer.register_schema(MOTION_SCHEMA, "protobuf", motion_schema())
        channel = writer.register_channel("/motion", "protobuf", schema)
        writer.add_metadata("motionkit", clip_module._metadata_record(walk))
        writer.add_message(channel, log_time=0, data=b"\x0a\xff", publish_time=0)
        writer.finish()
    return path


def _truncated(path: Path, robot: Robot, walk: Trajectory) -> Path:
    path.write_bytes(write(path, walk, robot).read_bytes()[:-100])
    return path


def _flipped(path: Path, robot: Robot, walk: Trajectory) -> Path:
    data = bytearray(write(path, walk, robot).read_bytes())
    data[len(data) // 3] ^= 0xFF  # inside the compressed motion: the index is intact
    path.write_bytes(bytes(data))
    return path


Maker = Callable[[Path, Robot, Trajectory], Path]

METADATA: dict[str, tuple[Maker, str]] = {
    "frames many": (lambda p, r, w: tampered(p, r, w, frames="many"),
                    r"'frames' should be a whole number of frames \(1 or more\), got 'many'"),
    "rate NaN": (lambda p, r, w: tampered(p, r, w, rate="NaN"),
                 r"metadata 'rate' should be a finite number >= 0, got 'NaN'"),
    "names not JSON": (lambda p, r, w: tampered(p, r, w, joint_names='["torso_pitch"'),
                       r"metadata 'joint_names' is not valid JSON"),
    "names a string": (lambda p, r, w: tampered(p, r, w, joint_names='"torso_pitch"'),
                       r"metadata 'joint_names' should be a list of names, got 'torso_pitch'"),
    "source a list": (lambda p, r, w: tampered(p, r, w, source="[1, 2]"),
                      r"metadata 'source' should be an object, got \[1, 2\]"),
    "flag not a boolean": (lambda p, r, w: tampered(p, r, w, has_throttle='"yes"'),
                           r"metadata 'has_throttle' should be true or false, got 'yes'"),
    "unknown kind": (lambda p, r, w: tampered(p, r, w, kind="dance"),
                     r"metadata kind 'dance' is not one of walk"),
    "frames beyond the motion": (lambda p, r, w: tampered(p, r, w, frames="500"),
                                 r"the metadata says 500 frames, /motion holds 120"),
    "rate not the motion's": (lambda p, r, w: tampered(p, r, w, rate="50.0"),
                              r"the metadata says rate 50, the motion 120"),
}  # fmt: skip

DATA: dict[str, tuple[Maker, str]] = {
    "flipped byte": (_flipped, r"CRC mismatch in the data section; the file is corrupt"),
    "no messages": (_no_messages, r"no /motion frames$"),
    "garbage payload": (
        _garbage_payload,
        r"/motion message at 0.000 s: truncated or invalid varint in a MotionChunk message",
    ),
    "NaN joint angle": (
        lambda p, r, w: _edited(p, r, w, "joint_positions", np.s_[5, 2], np.nan),
        r"finite values: joint_positions is not finite at frame 5",
    ),
    "time going back": (
        lambda p, r, w: _edited(p, r, w, "time", np.s_[40], 0.1),
        r"time: not strictly increasing at frame 40",
    ),
    "truncated": (_truncated, r"(the MCAP file is truncated|not a readable MCAP file)"),
}

VALUES: dict[str, tuple[Maker, str]] = {
    "beyond a joint limit": (
        lambda p, r, w: _edited(
            p, r, w, "joint_positions", np.s_[:, 0], w.joint_positions[:, 0] + 5
        ),
        r"joint position limits: 120 frames beyond; worst torso_pitch",
    ),
    "another model": (
        lambda p, r, w: tampered(p, r, w, robot_hash="0" * 16),
        r"robot model: clip made for ironcub model 0000000000000000",
    ),
}


def _clip(tmp_path: Path, robot: Robot, walk: Trajectory, maker: Maker) -> Path:
    path = tmp_path / "good.mcap"
    maker(path, robot, walk)
    return path


@pytest.mark.parametrize("case", [*METADATA, *DATA, *VALUES])
def test_validate_fails(
    case: str, tmp_path: Path, robot: Robot, walk: Trajectory, capsys: pytest.CaptureFixture
) -> None:
    maker, pattern = {**METADATA, **DATA, **VALUES}[case]
    path = _clip(tmp_path, robot, walk, maker)
    line = refused(["dataset", "validate", str(path)], capsys, 1, pattern, report=True)
    assert line.startswith(f"{path}: FAILED [FAIL] ")


@pytest.mark.parametrize("case", [*METADATA, *DATA])
def test_info_refuses(
    case: str, tmp_path: Path, robot: Robot, walk: Trajectory, capsys: pytest.CaptureFixture
) -> None:
    maker, pattern = {**METADATA, **DATA}[case]
    path = _clip(tmp_path, robot, walk, maker)
    refused(
        ["dataset", "info", str(path)],
        capsys,
        2,
        rf"^motionkit: error: {re.escape(str(path))}",
        pattern,
    )


def test_info_names_every_damaged_clip(
    tmp_path: Path, robot: Robot, walk: Trajectory, capsys: pytest.CaptureFixture
) -> None:
    write(tmp_path / "fine.mcap", walk, robot)
    (tmp_path / "a").mkdir()
    (tmp_path / "b").mkdir()
    _flipped(tmp_path / "a" / "good.mcap", robot, walk)
    _no_messages(tmp_path / "b" / "good.mcap", robot, walk)
    refused(["dataset", "info", str(tmp_path)], capsys, 2, r"2 damaged clips: .*a/good\.mcap: CRC "
            r"mismatch.*; .*b/good\.mcap: no /motion frames")  # fmt: skip
    assert main(["dataset", "info", str(tmp_path), "--index-only"]) == 0  # the index is intact
    assert "3 clips" in capsys.readouterr().out


def test_info_prints_clip_texts_without_control_characters(
    tmp_path: Path, robot: Robot, walk: Trajectory, capsys: pytest.CaptureFixture
) -> None:
    source = Source(clip="walk\x1b]0;pwned\x07", licence="CC\x1b[2J\nBY")
    meta = replace(walk.metadata, source=source, metrics={"a\nb": "c\rd"})
    path = write(tmp_path / "good.mcap", replace(walk, metadata=meta), robot)
    assert main(["dataset", "info", str(path)]) == 0
    out = capsys.readouterr().out
    assert "\x1b" not in out and "\x07" not in out and "\r" not in out
    lines = out.splitlines()
    assert lines[1].endswith(r"walk\x1b]0;pwned\x07 (CC\x1b[2J\nBY)")  # the clip's row
    assert lines[2].strip() == r"a\nb = c\rd" and lines[3] == ""
    assert main(["dataset", "info", str(path), "--json"]) == 0
    row = json.loads(capsys.readouterr().out)[0]
    assert row["source"]["licence"] == "CC\x1b[2J\nBY"  # JSON keeps the text, escaped


@pytest.mark.parametrize("case", [*METADATA, *DATA, *VALUES, "another robot"])
def test_export_refuses(
    case: str,
    tmp_path: Path,
    robot: Robot,
    walk: Trajectory,
    toy_robot: Robot,
    exported: Path,
    capsys: pytest.CaptureFixture,
) -> None:
    if case == "another robot":
        path = write(tmp_path / "good.mcap", synthetic_trajectory(toy_robot, 0.5), toy_robot)
        pattern = r"joint names of ironcub: missing \[.*\], unknown \['l_ankle'"
    else:
        maker, pattern = {**METADATA, **DATA, **VALUES}[case]
        path = _clip(tmp_path, robot, walk, maker)
    before = snapshot(exported)
    argv = ["dataset", "export", str(path), "--format", "npz", "--out", str(exported)]
    refused(argv, capsys, 2, rf"^motionkit: error: {re.escape(str(path))}", pattern)
    assert snapshot(exported) == before


@pytest.fixture
def no_server(monkeypatch: pytest.MonkeyPatch) -> None:
    pytest.importorskip("viser")
    import motionkit.viewer.app as app

    def refuse(*args: object, **kwargs: object) -> None:
        raise AssertionError("the server must not start")

    monkeypatch.setattr(app.viser, "ViserServer", refuse)


@pytest.mark.parametrize("case", [*METADATA, "flipped byte", "NaN joint angle", "time going back",
                                  "beyond a joint limit", "another robot"])  # fmt: skip
def test_view_refuses_before_serving(
    case: str,
    tmp_path: Path,
    robot: Robot,
    walk: Trajectory,
    toy_robot: Robot,
    no_server: None,
    capsys: pytest.CaptureFixture,
) -> None:
    if case == "another robot":
        path = write(tmp_path / "good.mcap", synthetic_trajectory(toy_robot, 0.5), toy_robot)
        pattern = r"the clip's joints \[.*\] are not those of robot 'ironcub'"
    else:
        maker, pattern = {**METADATA, **DATA, **VALUES}[case]
        path = _clip(tmp_path, robot, walk, maker)
    argv = ["view", str(path), "--port", "8099"]
    refused(argv, capsys, 2, rf"^motionkit: error: {re.escape(str(path))}", pattern)


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="no FIFOs on this system")
def test_fifo_clip_is_refused_not_waited_on(
    tmp_path: Path, no_server: None, capsys: pytest.CaptureFixture
) -> None:
    fifo = tmp_path / "good.mcap"
    os.mkfifo(fifo)
    with no_hang():
        for command in (["dataset", "info"], ["dataset", "export", "--format", "npz", "--out",
                        str(tmp_path / "out")], ["view"]):  # fmt: skip
            refused([*command, str(fifo)], capsys, 2, rf"{fifo}: cannot read the clip: a FIFO")
        line = refused(["dataset", "validate", str(fifo)], capsys, 1, r"a FIFO", report=True)
        assert str(fifo) in line
    assert not (tmp_path / "out").exists()


def test_console_script_refuses_a_damaged_clip(tmp_path: Path, robot, walk) -> None:
    """The installed command, in a process of its own: exit 2, one line, no traceback."""
    from test_cli import run

    path = _flipped(tmp_path / "good.mcap", robot, walk)
    result = run("dataset", "info", str(path))
    assert result.returncode == 2 and not result.stdout
    assert result.stderr.count("\n") == 1 and "Traceback" not in result.stderr
    assert result.stderr.startswith(f"motionkit: error: {path}: CRC mismatch")
