"""`motionkit trajopt --urdf --spec`: a take-off of the toy biped (two 100 N jets, 11 kg),
written for that robot, and a robot too heavy for its jets refused before anything is solved."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from motionkit import recipes
from motionkit.cli import main
from motionkit.dataset import read
from motionkit.robot import load_robot
from motionkit.trajopt.kinematics import GRAVITY

pytest.importorskip("casadi")
RECIPES = recipes.ROOT / "trajopt"


def takeoff(robot: tuple[Path, Path], out: Path) -> int:
    return main(
        ["trajopt", "--urdf", str(robot[0]), "--spec", str(robot[1]), "--scenario", "takeoff",
         "--config", str(RECIPES / "takeoff.toml"), "--knots", "10", "--height", "0.8",
         "--quiet", "--no-replay", "--out", str(out), "--name", "up"]
    )  # fmt: skip


def test_takeoff_of_the_toy_robot_is_written_for_it(
    toy_robot_files: tuple[Path, Path], tmp_path: Path
) -> None:
    robot = load_robot(*toy_robot_files)
    assert takeoff(toy_robot_files, tmp_path) == 0
    clip = read(tmp_path / "up.mcap")
    assert (clip.metadata.robot, clip.metadata.robot_hash) == ("toy", robot.model_hash)
    assert clip.joint_names == robot.joint_names and clip.joint_positions.shape[1] == 7
    assert clip.jet_names == ("a", "b") and clip.thrust.shape[1] == 2
    assert clip.contact_forces.shape[1:] == (8, 3)
    knots = np.load(tmp_path / "up.knots.npz")
    assert knots["com"][-1] == pytest.approx([0.0, 0.0, 0.8], abs=0.01)
    assert knots["thrust"].max() <= 100.0 + 1e-6  # the toy's T_max, not iRonCub's 250 N
    # hovering at the end: the two jets carry the toy's 11 kg (the jets point straight up)
    assert knots["thrust"][-1].sum() == pytest.approx(robot.total_mass * GRAVITY, rel=0.01)


def test_a_robot_its_jets_cannot_lift_is_refused(
    toy_robot_files: tuple[Path, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    spec = toy_robot_files[1]
    spec.write_text(spec.read_text().replace("t_max = 100.0", "t_max = 40.0"))
    assert takeoff(toy_robot_files, tmp_path / "out") == 1
    error = capsys.readouterr().err
    assert "toy cannot hover: its jets lift at most 80 N" in error and "weight is 108 N" in error
    assert not (tmp_path / "out").exists()
