"""Train configs from TOML: the recipes load, defaults are the paper's, bad input is refused
with the file, table and key named."""

from dataclasses import asdict
from pathlib import Path

import pytest

from motionkit import recipes
from motionkit.core.errors import TrainError
from motionkit.train.command import parse_priors
from motionkit.train.config import TrainConfig

RECIPES = recipes.ROOT / "train"


def test_paper_recipe_has_the_paper_settings() -> None:
    config = TrainConfig.from_toml(RECIPES / "paper_gpu.toml")
    ppo = config.ppo
    assert (ppo.gamma, ppo.learning_rate, ppo.kl_target, ppo.lam) == (0.99, 5e-5, 0.008, 0.95)
    assert (ppo.entropy_coef, ppo.clip, ppo.minibatch_size, ppo.value_coef) == (0, 0.2, 32768, 5)
    assert ppo.num_envs == 4096 and ppo.minibatches == 3
    assert sorted(config.priors) == ["flight", "walk"]
    assert config.env.control_hz == 60.0 and config.env.max_steps == 600  # 10 s episodes


def test_defaults_are_the_amp_reference_settings() -> None:
    config = TrainConfig()
    amp, ppo, env = config.amp, config.ppo, config.env
    assert (amp.gradient_penalty, amp.logit_reg, amp.weight_decay) == (5.0, 0.05, 1e-4)
    assert (amp.learning_rate, amp.style_scale, amp.replay_keep) == (5e-5, 2.0, 0.01)
    assert amp.buffer_size == 1_000_000 and amp.hidden == (1024, 512)
    assert (ppo.rollout_steps, ppo.epochs, ppo.lr_schedule) == (16, 6, "constant")
    assert (ppo.value_clip, ppo.bounds_coef, ppo.learn_std) == (0.0, 10.0, False)
    assert (env.action_mapping, env.action_scale, env.reset_from_prior) == ("range", 0.7, 0.85)


def test_gpu_recipes_are_the_cpu_recipes_at_a_gpus_scale() -> None:
    """Only the scale differs (environments, minibatches, networks, the discriminator's batch and
    buffer): control, rewards, jets and PPO's learning settings are the CPU runs'."""
    scale_ppo = {"num_envs", "minibatch_size", "actor_hidden", "critic_hidden"}
    scale_amp = {"hidden", "batch_size", "buffer_size"}
    for name in ("walk", "fly", "walk_fly"):
        gpu = TrainConfig.from_toml(RECIPES / f"{name}_gpu.toml")
        cpu = TrainConfig.from_toml(RECIPES / f"{name}_cpu.toml")
        assert gpu.env == cpu.env and gpu.reward == cpu.reward, name
        assert gpu.priors.keys() == cpu.priors.keys(), name
        assert gpu.curriculum == cpu.curriculum, name
        for ours, theirs, scale in ((gpu.ppo, cpu.ppo, scale_ppo), (gpu.amp, cpu.amp, scale_amp)):
            differ = {k for k, v in asdict(ours).items() if asdict(theirs)[k] != v}
            assert differ <= scale, (name, differ - scale)
        assert gpu.ppo.num_envs == 4096 and gpu.ppo.actor_hidden == (1024, 512), name
        assert gpu.run.max_minutes == 7.0, name
        # evaluations cover whole episodes (10 s at 30 Hz)
        assert gpu.run.eval_rollouts * gpu.ppo.rollout_steps >= gpu.env.max_steps == 300, name
    walk, fly = (TrainConfig.from_toml(RECIPES / f"{n}_gpu.toml") for n in ("walk", "fly"))
    # fly_gpu goes on from walk_gpu with --jets-at-rest: the rate action, then the set point
    assert (walk.env.jet_action, fly.env.jet_action) == ("rate", "thrust")


def test_round_trip_through_toml(tmp_path: Path) -> None:
    config = TrainConfig.from_toml(RECIPES / "paper_gpu.toml")
    path = tmp_path / "resolved.toml"
    path.write_text(config.to_toml())
    assert TrainConfig.from_toml(path) == config


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("[ppo]\nnum_envs = 10\nminibatch_size = 7\n", "multiple of minibatch_size"),
        ("[env]\nscenario = 'moon'\n", "scenario"),
        ("[env]\njet = 'lstm'\n", "jet_model"),
        ("[env]\njet_action = 'throttle'\n", "jet_action"),
        (
            "[env]\njet = 'lstm'\njet_model = 'm.npz'\njet_action = 'thrust'\n",
            "jet_action = 'thrust' needs jet = 'ideal'",
        ),
        ("[ppo]\ngamma = 'high'\n", "'gamma' should be float"),
        ("[reward]\nw_fly = 1.0\n", "unknown keys ['w_fly']"),
        ("[trainer]\n", "unknown keys ['trainer']"),
        ("[priors.walk]\nweight = 1.0\n", "[priors.walk]: missing 'paths'"),
        ("[priors.walk]\npaths = ['x']\nweight = -1.0\n", "weight"),
        ("[env]\nwaypoint_distance = [2.0, 0.7]\n", "waypoint_distance"),
        ("[run]\niterations = 0\n", "iterations"),
        (
            "[env]\nreset_from_prior = 1.5\n",
            "[env]: 'reset_from_prior' should be finite and in [0, 1], got 1.5",
        ),
        ("[env]\naction_mapping = 'wild'\n", "action_mapping"),
        ("[ppo]\nlr_schedule = 'cosine'\n", "lr_schedule"),
        ("[ppo]\nvalue_clip = -0.1\n", "[ppo]: 'value_clip' should be finite and >= 0"),
        ("[ppo]\njet_std = -0.2\n", "[ppo]: 'jet_std' should be finite and >= 0"),
        ("[amp]\nreplay_keep = 0.0\n", "replay_keep"),
        ("[amp]\nlogit_reg = nan\n", "[amp]: 'logit_reg' should be finite and >= 0, got nan"),
    ],
)
def test_bad_configs_are_refused(tmp_path: Path, text: str, message: str) -> None:
    path = tmp_path / "bad.toml"
    path.write_text(text)
    with pytest.raises(TrainError, match=None) as error:
        TrainConfig.from_toml(path)
    assert message in str(error.value)


def test_action_std_gives_the_jets_their_own() -> None:
    ppo = TrainConfig().ppo
    assert ppo.action_std(2, 1) == (0.05, 0.05, 0.05)  # jet_std 0: init_std for all
    ppo = TrainConfig.from_dict({"ppo": {"init_std": 0.07, "jet_std": 0.2}}).ppo
    assert ppo.action_std(3, 2) == (0.07, 0.07, 0.07, 0.2, 0.2)


def test_missing_file() -> None:
    with pytest.raises(TrainError, match="cannot read"):
        TrainConfig.from_toml(Path("/nonexistent/train.toml"))


def test_prior_selection() -> None:
    config = TrainConfig.from_toml(RECIPES / "paper_gpu.toml")
    assert parse_priors(None, ["walk", "flight"]) == ["walk", "flight"]
    assert parse_priors("none", ["walk"]) == []
    assert list(config.select_priors(parse_priors("flight", [])).priors) == ["flight"]
    with pytest.raises(TrainError, match="swim"):
        config.select_priors(["swim"])
    with pytest.raises(TrainError, match="expected"):
        parse_priors("walk,none", ["walk"])
