"""Hostile priors through `motionkit train`: a prior clip that `dataset validate` would fail
(NaN joint angles, another robot's joints) is refused before the run starts, with one line
naming the prior, the file and the frame or names, no traceback and no run folder."""

from __future__ import annotations

import re
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from hostile_support import refused

from motionkit.dataset import Trajectory, write
from motionkit.dataset.synthetic import synthetic_trajectory
from motionkit.robot import Robot, ironcub

pytest.importorskip("jax")


@pytest.fixture(scope="module")
def robot() -> Robot:
    return ironcub()


@pytest.fixture(scope="module")
def walk(robot: Robot) -> Trajectory:
    return synthetic_trajectory(robot, 1.0, seed=5)


def recipe(folder: Path, clip: Path) -> Path:
    path = folder / "recipe.toml"
    path.write_text(f'[run]\niterations = 1\n\n[priors.walk]\npaths = ["{clip}"]\n')
    return path


def nan_motion(path: Path, robot: Robot, walk: Trajectory, toy: Robot) -> Path:
    joints = np.array(walk.joint_positions)
    joints[7, 3] = np.nan
    return write(path, replace(walk, joint_positions=joints), robot)


def another_robot(path: Path, robot: Robot, walk: Trajectory, toy: Robot) -> Path:
    return write(path, synthetic_trajectory(toy, 1.0, seed=5), toy)


@pytest.mark.parametrize(
    ("maker", "pattern"),
    [
        (nan_motion, r"joint_positions is not finite at frame 7"),
        (another_robot, r"joint names of ironcub: missing \["),
    ],
)
def test_a_bad_prior_is_refused_before_training(
    maker, pattern: str, robot: Robot, walk: Trajectory, toy_robot, tmp_path: Path, capsys
) -> None:
    clip = maker(tmp_path / "bad_prior.mcap", robot, walk, toy_robot)
    out = tmp_path / "run"
    argv = ["train", "--config", str(recipe(tmp_path, clip)), "--out", str(out)]
    refused(argv, capsys, 2, r"prior 'walk'", re.escape(str(clip)), pattern)
    assert not out.exists()
