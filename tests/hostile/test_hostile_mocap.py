"""Hostile mocap files through `motionkit retarget`: each is refused with one line naming the file
and the problem (no traceback), and the earlier good output of the same clip stays as it was.

Every hostile take is named 07_03 like the good one: had it been accepted, it would have
overwritten the good output."""

from __future__ import annotations

import os
import re
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest
from hostile_support import no_hang, refused, snapshot
from mocap_synth import TRACKABLE, amc_text, bvh_text, synth_body, synth_motion, write_asf

from motionkit.cli import main
from motionkit.core.errors import MocapError
from motionkit.dataset import read_metadata
from motionkit.mocap.bvh import read_bvh

pytestmark = pytest.mark.filterwarnings("error::RuntimeWarning")  # no numpy noise either

BONES = synth_body()
VALUES = synth_motion(BONES, TRACKABLE)  # the good take passes the quality gate
GOOD_BVH = bvh_text(BONES, VALUES)
GOOD_AMC = amc_text(BONES, VALUES)


@pytest.fixture(scope="module")
def out(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A folder holding the good retargeted 07_03 and its summary."""
    source = tmp_path_factory.mktemp("good")
    (source / "07_03.bvh").write_text(GOOD_BVH)
    folder = source / "out"
    assert main(["retarget", str(source / "07_03.bvh"), "--out", str(folder), "--no-balance"]) == 0
    assert sorted(snapshot(folder)) == [
        ".motionkit-files.json",
        "07_03.mcap",
        "retarget_summary.json",
    ]
    return folder


def _motion_line(text: str, frame: int) -> int:
    """The index of motion frame `frame` among the BVH's lines."""
    return text.splitlines().index("Frame Time: 0.0083333") + 1 + frame


def _edit_value(frame: int, column: int, value: str) -> str:
    lines = GOOD_BVH.splitlines()
    n = _motion_line(GOOD_BVH, frame)
    words = lines[n].split()
    words[column] = value
    lines[n] = " ".join(words)
    return "\n".join(lines) + "\n"


def _scaled_offsets(factor: float) -> str:
    def scale(match: re.Match) -> str:
        return "OFFSET " + " ".join(f"{float(v) * factor:.6g}" for v in match[1].split())

    return re.sub(r"OFFSET (.*)", scale, GOOD_BVH)


def _nested(depth: int) -> str:
    """A BVH whose joints nest `depth` deep (a chain, no End Site)."""
    head = [
        "HIERARCHY",
        "ROOT Hips",
        "{",
        "OFFSET 0 0 0",
        "CHANNELS 3 Zrotation Xrotation Yrotation",
    ]
    for k in range(depth):
        head += [f"JOINT J{k}", "{", "OFFSET 0 1 0", "CHANNELS 1 Zrotation"]
    head += ["}"] * (depth + 1)
    values = " ".join(["0"] * (3 + depth))
    return "\n".join([*head, "MOTION", "Frames: 1", "Frame Time: 0.01", values]) + "\n"


# (file content, patterns the error line must match); the file is 07_03.bvh
BVH_CASES: dict[str, tuple[str | bytes, tuple[str, ...]]] = {
    "nan in a frame": (_edit_value(2, 7, "nan"), (r"line \d+: value 8 \(nan\) is not a finite",)),
    "inf in a frame": (_edit_value(4, 0, "-inf"), (r"value 1 \(-inf\) is not a finite",)),
    "nan offset": (
        GOOD_BVH.replace("OFFSET 0.000000000 0.000000000 0.000000000", "OFFSET nan 0 0", 1),
        (r"line 8: an OFFSET value 'nan' is not a finite number",),
    ),
    "huge offsets": (_scaled_offsets(1e100), (r"rest-pose leg is 1\.\d+e\+9\d m long, not 0\.1",)),
    "overflowing offsets": (_scaled_offsets(1e300), (r"rest-pose legs are inf file units long",)),
    "huge root motion": (_edit_value(3, 1, "1e12"), (r"root position of [\d.e+]+ m at frame 3",)),
    "zero channels": (
        re.sub(r"CHANNELS \d+ [A-Za-z ]+", "CHANNELS 0", GOOD_BVH),
        (r"no joint has CHANNELS: the file animates nothing",),
    ),
    "joints nested 300 deep": (_nested(300), (r"joint 'J200' is nested over 200 joints deep",)),
    "duplicate channel": (
        GOOD_BVH.replace(
            "CHANNELS 3 Zrotation Xrotation Yrotation",
            "CHANNELS 3 Zrotation Zrotation Yrotation",
            1,
        ),
        (r"line 9: channel 'Zrotation' twice in joint 'LHipJoint'",),
    ),
    "frames inf": (GOOD_BVH.replace("Frames: 6", "Frames: inf"), (r"expected 'Frames: <number>'",)),
    "frame time 1e-300": (
        GOOD_BVH.replace("Frame Time: 0.0083333", "Frame Time: 1e-300"),
        (r"'Frame Time: 1e-300': expected at least 0\.0001 s",),
    ),
    "empty file": ("", (r"cannot read the BVH file: the file is empty",)),
    "binary garbage": (
        np.random.default_rng(3).integers(0, 256, 4000, dtype=np.uint8).tobytes(),
        (r"line \d+: cannot read the BVH file: a NUL byte \(binary data\)",),
    ),
    "latin-1 joint name": (
        GOOD_BVH.replace("JOINT LeftLeg", "JOINT LeftLegé").encode("latin-1"),
        (r"line 14: cannot read the BVH file: byte 0xe9 is not UTF-8",),
    ),
}


def _write(folder: Path, name: str, content: str | bytes) -> Path:
    path = folder / name
    if isinstance(content, bytes):
        path.write_bytes(content)
    else:
        path.write_text(content)
    return path


def _refused_by_retarget(
    source: Path, out: Path, capsys: pytest.CaptureFixture, patterns: tuple[str, ...]
) -> None:
    before = snapshot(out)
    argv = ["retarget", str(source), "--out", str(out), "--no-balance"]
    with no_hang():
        line = refused(argv, capsys, 1, r"07_03: failed: ", re.escape(source.name), *patterns)
    assert str(source.parent) in line  # the whole path of the bad file
    assert snapshot(out) == before


@pytest.mark.parametrize("case", BVH_CASES)
def test_hostile_bvh(case: str, out: Path, tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    content, patterns = BVH_CASES[case]
    _refused_by_retarget(_write(tmp_path, "07_03.bvh", content), out, capsys, patterns)


def _amc_lines() -> list[str]:
    return GOOD_AMC.splitlines()


def _renumber(lines: list[str], old: str, new: str) -> list[str]:
    return [new if line == old else line for line in lines]


def _swap_frames() -> list[str]:
    return _renumber(_renumber(_renumber(_amc_lines(), "2", "x"), "3", "2"), "x", "3")


def _radians() -> str:
    values = {k: np.radians(v) for k, v in VALUES.items()}
    values["root"][:, :3] = VALUES["root"][:, :3]  # positions stay positions
    return amc_text(BONES, values)


# (edit of the AMC lines or an AMC text, patterns); the take is 07_03.amc beside 07.asf
AMC_CASES: dict[str, tuple[Callable[[], list[str] | str], tuple[str, ...]]] = {
    "frames out of order": (
        _swap_frames,
        (r"07_03\.amc: frame 2 comes after frame 3 \(out of order\)",),
    ),
    "frame repeated": (
        lambda: _renumber(_amc_lines(), "3", "2"),
        (r"07_03\.amc: frame 2 appears 2 times",),
    ),
    "frames missing": (
        lambda: [str(int(n) + 4) if n.isdigit() and int(n) >= 5 else n for n in _amc_lines()],
        (r"frames 5 to 8 are missing \(frame 9 follows 4\)",),
    ),
    "nan in a frame": (
        lambda: [re.sub(r"^ltibia .*", "ltibia NaN", line) for line in _amc_lines()],
        (r"07_03\.amc frame 1: bone 'ltibia' rx is nan, not a finite number",),
    ),
    "radians in a degrees file": (
        _radians,
        (
            r"read in degrees, but every rotation value lies within \+-pi \(largest 1\.047\)",
            r"add ':RADIANS'",
        ),
    ),
    "empty file": (lambda: "", (r"07_03\.amc: cannot read the AMC motion: the file is empty",)),
}


@pytest.mark.parametrize("case", AMC_CASES)
def test_hostile_amc(case: str, out: Path, tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    edit, patterns = AMC_CASES[case]
    write_asf(tmp_path / "07.asf", BONES)
    text = edit()
    content = text if isinstance(text, str) else "\n".join(text) + "\n"
    _refused_by_retarget(_write(tmp_path, "07_03.amc", content), out, capsys, patterns)


ASF_CASES: dict[str, tuple[Callable[[str], str], tuple[str, ...]]] = {
    "nan bone length": (
        lambda text: text.replace("length 7.3", "length nan", 1),
        (r"07\.asf line \d+: 'nan' holds a non-finite number",),
    ),
    "negative bone length": (
        lambda text: text.replace("length 7.3", "length -7.3", 1),
        (r"07\.asf line \d+: bone 'lfemur' has a negative length",),
    ),
    "hierarchy cycle": (
        lambda text: text.replace("root lhipjoint rhipjoint", "root rhipjoint").replace(
            "lfoot ltoes", "lfoot ltoes\n    ltoes lhipjoint"
        ),
        (
            r"07\.asf: bones not reachable from root in :hierarchy: \['lhipjoint', 'lfemur', "
            r"'ltibia', 'lfoot', 'ltoes'\] \(their parents form a cycle\)",
        ),
    ),
    "infinite units": (
        lambda text: text.replace("length 0.45", "length inf", 1),
        (r"07\.asf line 6: 'inf' holds a non-finite number",),
    ),
}


@pytest.mark.parametrize("case", ASF_CASES)
def test_hostile_asf(case: str, out: Path, tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    edit, patterns = ASF_CASES[case]
    asf = write_asf(tmp_path / "07.asf", BONES)
    asf.write_text(edit(asf.read_text()))
    amc = _write(tmp_path, "07_03.amc", GOOD_AMC)
    before = snapshot(out)
    argv = ["retarget", str(amc), "--out", str(out), "--no-balance"]
    refused(argv, capsys, 1, r"07_03: failed: ", *patterns)
    assert snapshot(out) == before


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="no FIFOs on this system")
def test_fifo_skeleton_is_refused_not_waited_on(
    out: Path, tmp_path: Path, capsys: pytest.CaptureFixture
) -> None:
    os.mkfifo(tmp_path / "07.asf")  # nobody ever writes to it
    amc = _write(tmp_path, "07_03.amc", GOOD_AMC)
    before = snapshot(out)
    with no_hang():
        argv = ["retarget", str(amc), "--out", str(out), "--no-balance"]
        refused(argv, capsys, 1, r"07\.asf: cannot read the ASF skeleton: a FIFO, not a regular")
        os.mkfifo(tmp_path / "fifo.bvh")
        with pytest.raises(MocapError, match=r"fifo\.bvh: cannot read the BVH file: a FIFO"):
            read_bvh(tmp_path / "fifo.bvh")
        argv = ["retarget", str(tmp_path / "fifo.bvh"), "--out", str(out), "--no-balance"]
        refused(argv, capsys, 2, r"fifo\.bvh: not a regular file or a folder")
    assert snapshot(out) == before


def test_a_clip_beyond_the_quality_gate_fails_unless_kept_elsewhere(
    out: Path, tmp_path: Path, capsys: pytest.CaptureFixture
) -> None:
    """The good take's motion in 6 frames instead of 60: faster than the robot's joints may
    move, so the IK's feet lag 4.3 cm behind their targets (the gate: 3 cm)."""
    write_asf(tmp_path / "07.asf", BONES)
    amc = _write(tmp_path, "07_03.amc", amc_text(BONES, synth_motion(BONES, 6)))
    before = snapshot(out)
    argv = ["retarget", str(amc), "--out", str(out), "--no-balance"]
    pattern = r"07_03: failed: beyond the clean figures: feet_error_mean_m 0\.04\d+ > 0\.03"
    refused(argv, capsys, 1, pattern, r"--keep-failed")
    assert snapshot(out) == before
    # asked to keep it: written with its figures to the other folder, OUT untouched
    held = tmp_path / "held"
    assert main([*argv, "--keep-failed", str(held)]) == 0
    assert "1 clip(s) beyond the clean figures written to" in capsys.readouterr().out
    assert snapshot(out) == before
    metrics = read_metadata(held / "07_03.mcap")[0].metrics
    assert 0.03 < metrics["feet_error_mean_m"] < 0.05
    refused([*argv, "--keep-failed", str(out)], capsys, 2, r"give another folder than --out")
