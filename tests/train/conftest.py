"""Shared, expensive things of the trainer tests: the tiny config, the environment and its
jitted batch reset/step (MJX compiles for tens of seconds on a CPU), synthetic priors, and a
persistent XLA compile cache so that a second trainer of the same config loads its programs."""

import os
from dataclasses import replace
from pathlib import Path

import pytest

from motionkit import recipes

jax = pytest.importorskip("jax")
pytest.importorskip("mujoco.mjx")

RECIPES = recipes.ROOT / "train"


@pytest.fixture(scope="session", autouse=True)
def _compile_cache(_private_cache: None) -> None:
    """The run's shared XLA cache (the root conftest's) for the programs compiled in-process."""
    jax.config.update("jax_compilation_cache_dir", os.environ["JAX_COMPILATION_CACHE_DIR"])
    jax.config.update("jax_persistent_cache_min_compile_time_secs", 1.0)


@pytest.fixture(scope="session")
def robot():
    from motionkit.robot import ironcub

    return ironcub()


@pytest.fixture(scope="session")
def tiny_config():
    from motionkit.train.config import TrainConfig

    return TrainConfig.from_toml(RECIPES / "tiny_cpu.toml")


@pytest.fixture(scope="session")
def env(robot, tiny_config):
    """The tiny environment on MJX (JAX): the backend that `batch_fns` steps."""
    from motionkit.train.env import Env

    return Env(robot, replace(tiny_config.env, impl="jax"), tiny_config.reward)


@pytest.fixture(scope="session")
def batch_fns(env):
    """Jitted vmapped (reset, step) of the tiny environment."""
    return jax.jit(jax.vmap(env.reset)), jax.jit(jax.vmap(env.step))


@pytest.fixture(scope="session")
def prior_files(robot, tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """Two synthetic priors: a walk (no thrust) and a 'flight' (110 N per jet), the base at
    0.6 m (1.1 cm below iRonCub's standing height): the seeded learning run of test_training.py
    was tuned on these, and at the standing height its 80 iterations show no trend."""
    from motionkit.dataset import write
    from motionkit.dataset.synthetic import synthetic_trajectory

    folder = tmp_path_factory.mktemp("priors")
    walk = synthetic_trajectory(robot, 3.0, 60.0, seed=1, base_height=0.6)
    flight = synthetic_trajectory(
        robot, 3.0, 60.0, thrust=110.0, seed=2, kind="flight", base_height=0.6
    )
    (folder / "walk").mkdir()
    return {
        "walk": write(folder / "walk" / "walk.mcap", walk, robot),
        "flight": write(folder / "flight.mcap", flight, robot),
    }


@pytest.fixture(scope="session")
def config_with_priors(tiny_config, prior_files):
    from motionkit.train.config import PriorConfig

    priors = {name: PriorConfig((str(path),)) for name, path in prior_files.items()}
    return replace(tiny_config, priors=priors)
