"""Hostile --out and --urdf paths through `motionkit dataset export` and `motionkit robot
export`: an --out that is a file, lies under a file or cannot be written, and a --urdf that is
a folder, are refused before any work with one line, no traceback, and the file unchanged."""

from __future__ import annotations

import os
import re
from pathlib import Path

import pytest
from hostile_support import refused

from motionkit.dataset import write
from motionkit.dataset.synthetic import synthetic_trajectory
from motionkit.robot import ironcub


@pytest.fixture(scope="module")
def clip(tmp_path_factory: pytest.TempPathFactory) -> Path:
    robot = ironcub()
    path = tmp_path_factory.mktemp("clip") / "walk.mcap"
    return write(path, synthetic_trajectory(robot, 0.5, seed=1), robot)


def exports(clip: Path, out: Path) -> list[list[str]]:
    return [
        ["dataset", "export", str(clip), "--format", "npz", "--out", str(out)],
        ["robot", "export", "--format", "mjcf", "--out", str(out)],
    ]


@pytest.mark.parametrize("where", ["a file", "under a file"])
def test_an_out_that_is_a_file_is_refused(where: str, clip: Path, tmp_path: Path, capsys) -> None:
    existing = tmp_path / "existing"
    existing.write_bytes(b"keep me")
    out = existing if where == "a file" else existing / "sub"
    for argv in exports(clip, out):
        refused(argv, capsys, 2, re.escape(f"{existing}: is a file, not a folder"))
    assert existing.read_bytes() == b"keep me"


@pytest.mark.skipif(os.geteuid() == 0, reason="root writes into read-only folders")
def test_an_out_that_cannot_be_written_is_refused(clip: Path, tmp_path: Path, capsys) -> None:
    locked = tmp_path / "locked"
    locked.mkdir()
    locked.chmod(0o555)
    try:
        for argv in exports(clip, locked / "out"):
            refused(argv, capsys, 2, r"cannot write there")
        assert list(locked.iterdir()) == []
    finally:
        locked.chmod(0o755)


def test_a_urdf_that_is_a_folder_is_refused(tmp_path: Path, capsys) -> None:
    folder, spec = tmp_path / "robot.urdf", tmp_path / "robot.toml"
    folder.mkdir()
    spec.write_text("")
    argv = ["robot", "export", "--format", "urdf", "--out", str(tmp_path / "out"), "--urdf",
            str(folder), "--spec", str(spec)]  # fmt: skip
    refused(argv, capsys, 2, re.escape(f"{folder}: cannot read URDF: a folder"))
    assert not (tmp_path / "out").exists()
