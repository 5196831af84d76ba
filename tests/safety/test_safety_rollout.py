"""The trainer's own rollout clips are valid dataset clips: their velocities are those their
positions imply (a tiny CPU run, about a minute of compiling)."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from motionkit import recipes

pytest.importorskip("mujoco.mjx")
pytestmark = pytest.mark.slow


def test_rollout_clip_validates(tmp_path: Path) -> None:
    from motionkit.dataset import read
    from motionkit.dataset.validate import validate_clip
    from motionkit.robot import ironcub
    from motionkit.train.config import TrainConfig
    from motionkit.train.runner import train

    config = TrainConfig.from_toml(recipes.find("train", "tiny_cpu")).select_priors([])
    config = replace(config, run=replace(config.run, iterations=1, tensorboard=False))
    robot = ironcub()
    train(config, tmp_path, robot, progress=lambda _: None)
    path = tmp_path / "rollouts" / "iter_1.mcap"
    checks = {c.name: c for c in validate_clip(path, robot)}
    failed = [c for c in checks.values() if not c.ok and not c.warning]
    assert not failed, failed
    assert checks["joint velocities = d/dt joint positions"].ok
    clip = read(path)
    assert clip.frames >= 10 and np.abs(clip.joint_velocities).max() > 0.01  # it moved
