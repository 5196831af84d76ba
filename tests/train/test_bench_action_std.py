"""benchmarks/bench_action_std.py without training: the recipe it writes for each std and the
means over thirds of a run that its table prints."""

import importlib.util
import math
import sys
from pathlib import Path
from typing import Any

import pytest

from motionkit import recipes
from motionkit.train.config import TrainConfig

BENCHMARKS = Path(__file__).resolve().parents[2] / "benchmarks"


@pytest.fixture(scope="module")
def bench() -> Any:
    sys.path.insert(0, str(BENCHMARKS))  # the script imports its sibling bench_amp
    try:
        spec = importlib.util.spec_from_file_location(
            "bench_action_std", BENCHMARKS / "bench_action_std.py"
        )
        assert spec is not None and spec.loader is not None
        module = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(module)
    finally:
        sys.path.remove(str(BENCHMARKS))
    return module


def test_recipe_is_walk_gpu_at_the_std_and_scale(bench: Any, tmp_path: Path) -> None:
    path = tmp_path / "std.toml"
    path.write_text(bench.recipe(tmp_path / "walk", 0.03, 32, 9, seed=4))
    config = TrainConfig.from_toml(path)
    walk_gpu = TrainConfig.from_toml(recipes.find("train", "walk_gpu"))
    assert config.ppo.init_std == 0.03 and config.ppo.num_envs == 32
    assert config.ppo.minibatch_size == 32 * 16 // 2  # two minibatches per epoch
    assert (config.run.iterations, config.run.seed, config.run.eval_every) == (9, 4, 0)
    assert config.run.eval_rollouts == 19  # ceil(300 steps (10 s at 30 Hz) / 16): one episode
    assert config.priors["walk"].paths == (str(tmp_path / "walk"),)
    assert config.env == walk_gpu.env and config.reward == walk_gpu.reward
    assert config.ppo.actor_hidden == walk_gpu.ppo.actor_hidden == (1024, 512)


def test_third_means(bench: Any) -> None:
    rows = [{"kl": float(k)} for k in (1, 2, 3, 4, 5, 6, 7)] + [{"kl": math.nan}]
    # thirds of 8 rows: 3, 3, 2; a NaN (no episode ended) is left out of its mean
    assert bench.third_means(rows, "kl") == [2.0, 5.0, 7.0]
    assert all(math.isnan(x) for x in bench.third_means([{}] * 3, "kl"))
