"""The walk_fly_jets_cpu recipe: walk_fly_cpu's final task with the fitted jets (the paper's LSTM
variant: a 15 % throttle floor, thrust penalty 1e-8), the pipeline's jet model, and a header
command that `motionkit train` parses as a new run from the shipped policy's actor."""

import shlex
from dataclasses import asdict
from pathlib import Path

import pytest

from motionkit import recipes
from motionkit.cli import build_parser
from motionkit.pipeline.stages import STAGE_FOLDERS
from motionkit.train.config import TrainConfig

RECIPE = recipes.find("train", "walk_fly_jets_cpu")
# the keys it changes from walk_fly_cpu's tables
CHANGED = {
    "env": {"jet": "lstm", "jet_model": "datasets/jet/model.npz", "throttle_min": 15.0,
            "jet_action": "rate"},
    "reward": {"w_thrust": 1e-8},
}  # fmt: skip


@pytest.fixture(scope="module")
def config() -> TrainConfig:
    return TrainConfig.from_toml(RECIPE)


def test_it_is_walk_fly_cpus_final_task_with_fitted_jets(config: TrainConfig) -> None:
    base = TrainConfig.from_toml(recipes.find("train", "walk_fly_cpu"))
    assert base.curriculum and not config.curriculum
    assert base.env.jet_action == "thrust"  # the ideal jet's set point; a throttle here
    for table in ("env", "reward", "ppo", "amp", "run"):
        ours, theirs = asdict(getattr(config, table)), asdict(getattr(base, table))
        changed = CHANGED.get(table, {})
        assert {k: ours[k] for k in changed} == changed, table
        assert {k: v for k, v in ours.items() if k not in changed} == {
            k: v for k, v in theirs.items() if k not in changed
        }, table
    assert config.priors == base.priors


def test_its_jet_model_is_the_pipelines(config: TrainConfig) -> None:
    """`motionkit pipeline --out datasets` writes the priors to datasets/walk and
    datasets/flight, and the jet stage's model to datasets/jet/model.npz."""
    out = Path(config.priors["walk"].paths[0]).parent
    assert Path(config.priors["flight"].paths[0]).parent == out == Path("datasets")
    assert "jet" in STAGE_FOLDERS
    assert Path(config.env.jet_model) == out / "jet" / "model.npz"


def test_the_header_command_parses() -> None:
    lines = [line for line in RECIPE.read_text().splitlines() if "motionkit train --" in line]
    assert len(lines) == 1
    argv = shlex.split(lines[0].lstrip("# "))
    assert argv[:2] == ["motionkit", "train"]
    args = build_parser().parse_args(argv[1:])
    assert args.config == RECIPE and args.out == Path("RUN")
    assert args.init_from == "walk_fly" and args.jets_at_rest and args.resume_from is None
