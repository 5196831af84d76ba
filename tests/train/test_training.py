"""A tiny seeded training run on the CPU through `motionkit.train.runner.train`: the
discriminator learns to tell the priors from the policy's (random) motion without saturating,
the task reward rises, and the run folder has its logs, checkpoint and evaluation rollout;
resume continues."""

import csv
import json
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from motionkit.core.errors import TrainError

pytestmark = pytest.mark.slow  # compiles the rollout and the update (about 1-2 minutes)

ITERATIONS = 160


def learning_config(config):
    """The tiny recipe with fast jets (3,000 N/s) and a thrust penalty of weight 0.5 (not 0.11):
    random jet inputs blow the robot about and cost thrust penalty, so a quick, clear task to
    learn is to throttle them down."""
    env = replace(config.env, thrust_rate_max=3000.0)
    reward = replace(config.reward, w_thrust=0.5)
    run = replace(config.run, iterations=ITERATIONS, checkpoint_every=ITERATIONS, seed=0)
    return replace(config, env=env, reward=reward, run=run)


@pytest.fixture(scope="module")
def run_folder(config_with_priors, robot, tmp_path_factory: pytest.TempPathFactory) -> Path:
    from motionkit.train.runner import train

    out = tmp_path_factory.mktemp("run")
    lines: list[str] = []
    train(learning_config(config_with_priors), out, robot, progress=lines.append)
    assert any(line.startswith(f"iter {ITERATIONS}:") for line in lines)
    return out


def read_csv(path: Path) -> dict[str, np.ndarray]:
    with path.open() as stream:
        rows = list(csv.DictReader(stream))
    return {key: np.array([float(r[key] or "nan") for r in rows]) for key in rows[0]}


def test_discriminator_separates_prior_from_policy_motion(run_folder: Path) -> None:
    log = read_csv(run_folder / "train.csv")
    start = 0.5 * (log["disc_expert_accuracy_start"] + log["disc_policy_accuracy_start"])
    accuracy = 0.5 * (log["disc_expert_accuracy"] + log["disc_policy_accuracy"])
    assert start[0] < 0.75  # the initial discriminator: near chance
    assert accuracy[:10].max() > 0.95  # it tells the random policy from the priors at once
    # style reward 2 softplus(D): about 2 log 2 at first; the regularised discriminator does
    # not saturate, so the style reward stays well above 0 as the policy comes closer
    assert log["style_reward"][0] > 1.0
    assert log["style_reward"][-10:].mean() > 0.2
    assert log["disc_policy_accuracy_rollout"][-10:].mean() < 0.99


def test_task_reward_rises(run_folder: Path) -> None:
    """Over the rest of the run the task reward is higher and the thrust penalty lower than in
    its first ten iterations. With the thrust weight at 0.11 the rise was within the noise of
    the float path (seed 0 on an AMX Xeon: +0.017, thrust penalty -0.94 to -0.85); at 0.5,
    seeds 0, 1 and 2 there rose by 0.195, 0.231 and 0.244, the penalty falling to 0.50, 0.44
    and 0.44 of the first ten's."""
    log = read_csv(run_folder / "train.csv")
    rest = slice(10, ITERATIONS)
    first, later = log["task_reward"][:10].mean(), log["task_reward"][rest].mean()
    assert later > first + 0.1, (first, later)
    thrust_first, thrust_later = log["reward_thrust"][:10].mean(), log["reward_thrust"][rest].mean()
    assert thrust_later > 0.7 * thrust_first, (thrust_first, thrust_later)  # penalties are < 0


def test_run_folder_contents(run_folder: Path, robot) -> None:
    from motionkit.dataset import read
    from motionkit.dataset.validate import validate_clip
    from motionkit.train.config import TrainConfig

    log = read_csv(run_folder / "train.csv")
    np.testing.assert_array_equal(log["iteration"], np.arange(1, ITERATIONS + 1))
    assert np.all(np.isfinite(log["reward"])) and np.all(log["env_steps_per_second"] > 0)
    evaluation = read_csv(run_folder / "eval.csv")
    assert evaluation["iteration"].tolist() == [ITERATIONS]
    share = evaluation["eval_airborne_share"] + evaluation["eval_ground_share"]
    np.testing.assert_allclose(share, 1.0, rtol=1e-5)  # float32 shares
    assert (run_folder / "checkpoint.msgpack").stat().st_size > 1000
    assert (run_folder / "curves.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    config = TrainConfig.from_toml(run_folder / "config.toml")
    assert config.run.iterations == ITERATIONS and sorted(config.priors) == ["flight", "walk"]
    summary = json.loads((run_folder / "summary.json").read_text())
    assert summary["priors"]["walk"]["clips"] == 1 and summary["iterations"] == ITERATIONS
    clip = read(run_folder / "rollouts" / f"iter_{ITERATIONS}.mcap")
    checks = validate_clip(run_folder / "rollouts" / f"iter_{ITERATIONS}.mcap", robot)
    assert all(c.ok or c.warning for c in checks), [c for c in checks if not c.ok]
    assert clip.metadata.kind == "rollout" and clip.frames >= 2
    route = clip.metadata.config["waypoints"]
    assert len(route[0]) == 4 and route[0][0] == 0.0  # [time, x, y, z]
    assert np.all(np.isfinite(clip.base_position))


def test_resume_continues_and_refuses_to_overwrite(
    run_folder: Path, config_with_priors, robot
) -> None:
    from motionkit.train.runner import train

    config = learning_config(config_with_priors)
    with pytest.raises(TrainError, match="--resume"):
        train(config, run_folder, robot, progress=lambda _: None)
    more = replace(config, run=replace(config.run, iterations=ITERATIONS + 2, eval_every=0))
    lines: list[str] = []
    summary = train(more, run_folder, robot, resume=True, progress=lines.append)
    assert lines[0] == f"resumed {run_folder} at iteration {ITERATIONS}"
    assert summary["iterations"] == ITERATIONS + 2
    log = read_csv(run_folder / "train.csv")
    assert log["iteration"][-2:].tolist() == [ITERATIONS + 1, ITERATIONS + 2]


def test_missing_prior_is_a_clear_error(tiny_config, robot, tmp_path: Path) -> None:
    from motionkit.train.config import PriorConfig
    from motionkit.train.runner import train

    config = replace(tiny_config, priors={"walk": PriorConfig(("no/such/folder",))})
    with pytest.raises(TrainError, match="prior 'walk': no/such/folder: no such file"):
        train(config, tmp_path / "out", robot)
    assert not (tmp_path / "out").exists()


def test_resume_from_a_carried_checkpoint_into_a_new_folder(
    run_folder: Path, config_with_priors, robot, tmp_path: Path, capsys
) -> None:
    """`motionkit train --resume-from FILE` (a checkpoint carried from another machine)
    starts a new run folder at the checkpoint's iteration."""
    from flax import serialization

    from motionkit.cli import main

    carried = tmp_path / "carried.msgpack"
    carried.write_bytes((run_folder / "checkpoint.msgpack").read_bytes())
    at = int(serialization.msgpack_restore(carried.read_bytes())["iteration"])
    config = learning_config(config_with_priors)
    recipe = tmp_path / "recipe.toml"
    recipe.write_text(replace(config, run=replace(config.run, eval_every=0)).to_toml())
    out = tmp_path / "new"
    args = ["train", "--config", str(recipe), "--out", str(out), "--resume-from", str(carried)]
    assert at >= ITERATIONS and main([*args, "--iterations", str(at + 1), "--jets-at-rest"]) == 0
    printed = capsys.readouterr().out
    assert f"copied {carried} to {out}" in printed
    assert f"resumed {out} at iteration {at}" in printed
    assert "the policy's jet outputs start at rest (rate action)" in printed
    assert read_csv(out / "train.csv")["iteration"].tolist() == [at + 1]
    resumed = ["train", "--config", str(recipe), "--out", str(out), "--iterations", str(at + 2)]
    capsys.readouterr()
    assert main([*resumed, "--resume-from", str(out / "checkpoint.msgpack"), "--jets-at-rest"]) == 2
    assert "the run's own checkpoint" in capsys.readouterr().err
    assert main([*resumed, "--resume", "--jets-at-rest"]) == 2
    assert "--jets-at-rest needs --resume-from" in capsys.readouterr().err


def test_jets_at_rest_keeps_the_joints(env, tiny_config) -> None:
    """Trainer.jets_at_rest: the mean's jet outputs are the rest action for any observation,
    the joints' outputs are unchanged."""
    import jax
    import jax.numpy as jnp

    from motionkit.train.learner import Trainer

    config = replace(tiny_config, env=env.config, priors={})
    trainer = Trainer(config, env)
    learner, _ = trainer.init(0)
    noisy = jax.tree.map(lambda x: x + 0.1, learner.policy)  # jet outputs away from rest
    learner = learner.replace(policy=noisy)
    obs = jax.random.normal(jax.random.key(1), (5, env.obs_size))
    before = trainer.net.apply(learner.policy, obs)[0]
    after = trainer.net.apply(trainer.jets_at_rest(learner).policy, obs)[0]
    joints = env.num_joints
    np.testing.assert_array_equal(np.asarray(after[:, :joints]), np.asarray(before[:, :joints]))
    rest = np.broadcast_to(np.asarray(env.rest_action[joints:]), (5, env.num_jets))
    np.testing.assert_array_equal(np.asarray(after[:, joints:]), rest)
    assert not np.allclose(np.asarray(before[:, joints:]), rest)
    assert jnp.all(jnp.isfinite(after))


def test_place_checkpoint_refusals(tmp_path: Path) -> None:
    from motionkit.train.checkpoint import NAME, place_checkpoint

    source = tmp_path / "carried.msgpack"
    with pytest.raises(TrainError, match=r"^--resume-from .*carried.msgpack: no such checkpoint"):
        place_checkpoint(tmp_path / "out", source, "--resume-from")
    assert not (tmp_path / "out").exists()
    source.write_bytes(b"learner")
    assert place_checkpoint(tmp_path / "out", source, "--resume-from")
    own = tmp_path / "out" / NAME
    assert own.read_bytes() == b"learner"
    assert not place_checkpoint(tmp_path / "out", own, "--resume-from")  # the run's own
    with pytest.raises(TrainError, match="holds another run"):
        place_checkpoint(tmp_path / "out", source, "--resume-from")


@pytest.mark.parametrize("bias", [5.0, -5.0])
def test_the_evaluation_reads_the_discriminator(run_folder: Path, robot, bias: float) -> None:
    """A discriminator that answers the same logit everywhere: the evaluation's accuracy on
    policy samples is 0 (all taken for prior motion) or 1, its style reward 2 softplus(bias)."""
    import jax
    import jax.numpy as jnp

    from motionkit.train.config import TrainConfig
    from motionkit.train.evaluate import evaluate
    from motionkit.train.runner import build_trainer

    config = TrainConfig.from_toml(run_folder / "config.toml")
    _, trainer, _ = build_trainer(config, robot, with_priors=False)
    learner, _ = trainer.init(0)
    constant = jax.tree.map(jnp.zeros_like, learner.disc)
    constant["params"]["logit"]["bias"] = jnp.full_like(constant["params"]["logit"]["bias"], bias)
    learner = learner.replace(disc=constant)
    figures, _ = evaluate(trainer, learner, jax.random.key(0), chunks=1)
    assert figures["eval_disc_policy_accuracy"] == (0.0 if bias > 0 else 1.0)
    assert figures["eval_style_reward"] == pytest.approx(2 * np.logaddexp(0.0, bias), rel=1e-5)
