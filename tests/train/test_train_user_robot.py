"""`motionkit train --urdf --spec`: a one-iteration run of the toy biped (7 joints, 2 jets) on
the CPU, whose outputs are made for that robot."""

import json
from pathlib import Path

from motionkit.cli import main
from motionkit.dataset import read
from motionkit.robot import load_robot

TINY = """
[env]
episode_seconds = 0.5
[ppo]
num_envs = 4
rollout_steps = 4
epochs = 1
minibatch_size = 16
actor_hidden = [16]
critic_hidden = [16]
[run]
iterations = 1
eval_every = 0
eval_rollouts = 1
"""


def test_training_the_toy_robot_writes_its_rollouts(
    toy_robot_files: tuple[Path, Path], tmp_path: Path, capsys
) -> None:
    recipe, out = tmp_path / "tiny.toml", tmp_path / "run"
    recipe.write_text(TINY)
    urdf, spec = toy_robot_files
    argv = ["train", "--config", str(recipe), "--out", str(out), "--priors", "none"]
    assert main([*argv, "--urdf", str(urdf), "--spec", str(spec)]) == 0
    assert "actions 9" in capsys.readouterr().out  # 7 joint targets and 2 jet inputs
    assert json.loads((out / "summary.json").read_text())["iterations"] == 1
    robot = load_robot(urdf, spec)
    clip = read(out / "rollouts" / "iter_1.mcap")
    assert (clip.metadata.robot, clip.metadata.robot_hash) == ("toy", robot.model_hash)
    assert clip.joint_positions.shape[1] == 7 and clip.thrust.shape[1] == 2
    assert clip.metadata.generator == "rollout" and clip.jet_names == ("a", "b")
