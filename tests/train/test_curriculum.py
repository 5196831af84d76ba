"""A recipe's curriculum: stages read and checked from TOML, their configs, the switch rules
(goals held at evaluations, iteration limits), and a tiny run that switches stages, logs the
switch and goes on in the saved stage when resumed."""

import csv
import json
import tomllib
from dataclasses import replace
from pathlib import Path

import pytest

from motionkit import recipes
from motionkit.core.errors import TrainError
from motionkit.train.config import TrainConfig
from motionkit.train.curriculum import (
    CurriculumState,
    advance,
    goal_figures,
    read_state,
    write_state,
)

STAGES = """
[priors.walk]
paths = ["walk"]

[priors.flight]
paths = ["flight"]

[curriculum.first]
env = { air_probability = 0.0 }
ppo = { init_std = 0.2 }
priors = { flight = 0.25 }
goals = { eval_waypoints_per_episode = ">= 2", eval_falls_per_episode = "<= 0.1" }
hold = 2
max_iterations = 10

[curriculum.second]
"""


def config_of(text: str) -> TrainConfig:
    return TrainConfig.from_dict(tomllib.loads(text), "recipe.toml")


def test_a_stage_changes_only_its_keys_and_weights() -> None:
    config = config_of(STAGES)
    first, second = config.stage("first"), config.stage("second")
    assert first.env.air_probability == 0.0 and config.env.air_probability == 0.5
    assert first.ppo.init_std == 0.2 and second.ppo.init_std == config.ppo.init_std
    assert first.priors["flight"].weight == 0.25 and first.priors["walk"].weight == 1.0
    assert replace(first, env=config.env, ppo=config.ppo, priors=config.priors) == replace(
        config, curriculum={}
    )
    assert second == replace(config, curriculum={})
    # the resolved config (config.toml of a run) reads back the same
    assert config_of(config.to_toml()) == config


@pytest.mark.parametrize(
    ("table", "message"),
    [
        ("env = { air_probabilty = 0.0 }", "unknown keys ['air_probabilty']"),
        ("env = { air_probability = 2.0 }", "'air_probability' should be finite and in [0, 1]"),
        ("ppo = { actor_hidden = [8] }", "cannot change between stages"),
        ("priors = { swim = 1.0 }", "names ['swim']"),
        ("priors = { walk = 0.0 }", "'priors.walk' should be a weight > 0"),
        ('goals = { eval_speed = "> 1" }', "'goals.eval_speed' should be '>= x' or '<= x'"),
        ('goals = { eval_speed = ">= fast" }', "'>= x' or '<= x'"),
        ("hold = 0", "'hold' should be finite and >= 1"),
    ],
)
def test_a_bad_stage_is_refused_naming_it(table: str, message: str) -> None:
    text = STAGES.replace("[curriculum.second]", f"[curriculum.second]\n{table}")
    with pytest.raises(TrainError, match=r"\[curriculum\.second[]\.]") as error:
        config_of(text)
    assert message in str(error.value)


def test_a_stage_ends_when_its_goals_hold_or_its_iterations_run_out() -> None:
    config = config_of(STAGES)
    met = {"eval_waypoints_per_episode": 2.0, "eval_falls_per_episode": 0.1}
    missed = met | {"eval_falls_per_episode": 0.2}
    state = CurriculumState(since=100)
    state, why = advance(config, state, 102, met)  # the first of two evaluations in a row
    assert (state.stage, state.held, why) == (0, 1, "")
    state, why = advance(config, state, 104, missed)  # the row is broken
    assert (state.stage, state.held, why) == (0, 0, "")
    state, why = advance(config, state, 105, None)  # no evaluation: nothing changes
    assert (state.stage, state.held, why) == (0, 0, "")
    state, _ = advance(config, state, 106, met)
    state, why = advance(config, state, 108, met)
    assert state == CurriculumState(1, 108, 0, state.switches)
    assert why == "goals met: eval_waypoints_per_episode 2 >= 2, eval_falls_per_episode 0.1 <= 0.1"
    assert state.switches == ({"iteration": 108, "from": "first", "to": "second", "why": why},)
    # the last stage never ends
    assert advance(config, state, 10_000, met) == (state, "")
    # without goals met, max_iterations ends the stage
    state, why = advance(config, CurriculumState(since=100), 110, missed)
    assert (state.stage, why) == (1, "10 iterations in the stage")
    with pytest.raises(TrainError, match="no such evaluation or training figure"):
        advance(config, CurriculumState(), 1, {"eval_speed": 1.0})


def test_a_goal_on_a_training_figure_uses_its_mean_since_the_last_evaluation() -> None:
    nan = float("nan")
    window = [{"falls_per_episode": 0.3, "speed": nan}, {"falls_per_episode": 0.1, "speed": nan}]
    figures = goal_figures({"eval_falls_per_episode": 0.0}, window)
    assert figures["eval_falls_per_episode"] == 0.0
    assert figures["falls_per_episode"] == pytest.approx(0.2)  # (0.3 + 0.1) / 2
    assert figures["speed"] != figures["speed"]  # no finite value: nan, a goal never met
    config = config_of(STAGES.replace("eval_falls_per_episode", "falls_per_episode"))
    met = {"eval_waypoints_per_episode": 2.5}
    state, why = advance(config, CurriculumState(since=195, held=1), 200, goal_figures(met, window))
    assert (state.stage, why) == (0, "")  # 0.2 > 0.1
    window = [{"falls_per_episode": 0.1}, {"falls_per_episode": 0.05}]
    state, why = advance(config, CurriculumState(since=195, held=1), 200, goal_figures(met, window))
    assert state.stage == 1
    assert why == "goals met: eval_waypoints_per_episode 2.5 >= 2, falls_per_episode 0.075 <= 0.1"


def test_the_state_round_trips_and_must_match_the_curriculum(tmp_path: Path) -> None:
    config = config_of(STAGES)
    assert read_state(tmp_path, config) is None
    state = CurriculumState(1, 108, 0, ({"iteration": 108, "from": "first", "to": "second"},))
    write_state(tmp_path, config, state)
    assert read_state(tmp_path, config) == state
    renamed = config_of(STAGES.replace("curriculum.second", "curriculum.other"))
    with pytest.raises(TrainError, match="'second' is not stage 1"):
        read_state(tmp_path, renamed)


def test_the_built_in_walk_fly_recipe_reads_its_stages() -> None:
    config = TrainConfig.from_toml(recipes.find("train", "walk_fly_cpu"))
    assert list(config.curriculum) == ["walk_explore", "walk", "fly", "walk_fly"]
    assert config.stage("walk_explore").env.air_probability == 0.0
    assert config.stage("fly").env.air_probability == 1.0
    assert config.stage("walk_fly") == replace(config, curriculum={})


@pytest.mark.slow
def test_a_run_switches_stages_and_resumes_in_its_stage(tiny_config, robot, tmp_path) -> None:
    from motionkit.train.runner import train

    text = """
[curriculum.short]
reward = { w_thrust = 0.2 }
max_iterations = 3

[curriculum.rest]
reward = { w_thrust = 0.5 }
"""
    run = replace(tiny_config.run, iterations=5, checkpoint_every=2, eval_every=2)
    stages = config_of(text).curriculum
    config = replace(tiny_config, run=run, curriculum=stages)
    lines: list[str] = []
    train(config, tmp_path, robot, progress=lines.append)
    assert any("stage ends at iteration 3 (3 iterations in the stage)" in x for x in lines)
    assert any(x.startswith("curriculum stage 2/2 'rest' since iteration 3") for x in lines)
    with (tmp_path / "train.csv").open() as stream:
        stages_logged = [float(row["stage"]) for row in csv.DictReader(stream)]
    assert stages_logged == [0, 0, 0, 1, 1]
    saved = json.loads((tmp_path / "curriculum.json").read_text())
    assert (saved["stage"], saved["since"], saved["name"]) == (1, 3, "rest")
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert summary["curriculum"][0]["to"] == "rest"
    # resumed, the run goes on in stage 'rest'
    more = replace(config, run=replace(run, iterations=6))
    lines.clear()
    train(more, tmp_path, robot, resume=True, progress=lines.append)
    assert any(x.startswith("curriculum stage 2/2 'rest' since iteration 3") for x in lines)
    with (tmp_path / "train.csv").open() as stream:
        assert [float(row["stage"]) for row in csv.DictReader(stream)][-1] == 1
    # evaluated again, in the stage of the latest checkpoint: the run's last evaluation
    from motionkit.train.runner import evaluate_run

    with (tmp_path / "eval.csv").open() as stream:
        last = list(csv.DictReader(stream))[-1]
    again = evaluate_run(tmp_path, robot)
    for name in ("eval_task_reward", "eval_approach_speed", "eval_reward_thrust"):
        assert again[name] == pytest.approx(float(last[name]), rel=1e-5, abs=1e-7)
    # in the first stage's config the thrust term weighs 0.2, not 0.5: the same motion (the
    # same thrust term), another task reward
    first = evaluate_run(tmp_path, robot, stage="short")
    assert first["eval_reward_thrust"] == pytest.approx(again["eval_reward_thrust"], rel=1e-5)
    assert first["eval_task_reward"] != pytest.approx(again["eval_task_reward"], rel=1e-4)
    with pytest.raises(TrainError, match=r"no curriculum stage 'long' .*short, rest"):
        evaluate_run(tmp_path, robot, stage="long")
