"""A new run from a trained policy's actor (`--init-from`): the layers and normaliser carried
over, and a flat-ground policy widened to a terrain's height map acting as before where every
cell of the map is the flat ground (minus the base height)."""

from dataclasses import replace
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from motionkit.core.errors import TrainError
from motionkit.train.normalize import RunningNorm
from motionkit.train.warm_start import CENTRE, MAP_CELLS, init_from_policy, widen_to_height_map


def flat_to_map(obs: np.ndarray, heights_at: int) -> np.ndarray:
    """A flat-ground observation as a terrain one: each of the map's cells is minus the base
    height (the ground relative to the base)."""
    cells = np.full(MAP_CELLS, -obs[heights_at])
    return np.concatenate([obs[:heights_at], cells, obs[heights_at + 1 :]])


def test_the_widened_first_layer_sees_the_map_of_flat_ground_as_the_one_height() -> None:
    rng = np.random.default_rng(0)
    kernel = rng.normal(size=(6, 4)).astype(np.float32)
    norm = RunningNorm(jnp.asarray(rng.normal(size=6)), jnp.asarray(rng.uniform(0.5, 2, 6)), 9.0)
    wide_kernel, wide_norm = widen_to_height_map(kernel, norm, heights_at=2)
    assert wide_kernel.shape == (6 + MAP_CELLS - 1, 4)
    np.testing.assert_array_equal(wide_kernel[2 + CENTRE], -kernel[2])
    others = np.delete(wide_kernel[2 : 2 + MAP_CELLS], CENTRE, axis=0)
    np.testing.assert_array_equal(others, 0.0)
    np.testing.assert_array_equal(wide_kernel[2 + MAP_CELLS :], kernel[3:])
    assert float(wide_norm.mean[2 + CENTRE]) == pytest.approx(-float(norm.mean[2]))
    assert float(wide_norm.var[2 + CENTRE]) == pytest.approx(float(norm.var[2]))
    for _ in range(3):
        obs = rng.normal(size=6).astype(np.float32)
        before = np.asarray(norm(jnp.asarray(obs))) @ kernel
        after = np.asarray(wide_norm(jnp.asarray(flat_to_map(obs, 2)))) @ wide_kernel
        np.testing.assert_allclose(after, before, rtol=1e-5, atol=1e-5)


@pytest.mark.slow
def test_a_flat_policy_starts_a_terrain_run_acting_as_before(tiny_config, robot) -> None:
    from motionkit.train.policy import Policy
    from motionkit.train.ppo import Actor, actor_params
    from motionkit.train.runner import build_trainer

    _, flat_trainer, _ = build_trainer(tiny_config, robot, with_priors=False)
    flat_learner, _ = flat_trainer.init(0)
    hidden = tuple(tiny_config.ppo.actor_hidden)
    size = flat_trainer.env.obs_size
    rng = np.random.default_rng(1)
    norm = RunningNorm(
        jnp.asarray(rng.normal(size=size)), jnp.asarray(rng.uniform(0.5, 2, size)), 50.0
    )
    policy = Policy(
        Path("flat"), tiny_config, actor_params(jax.device_get(flat_learner.policy), hidden),
        norm, {}, {},
    )  # fmt: skip
    terrain_env = replace(tiny_config.env, scenario="terrain", terrain_levels=2)
    terrain = replace(tiny_config, env=terrain_env)
    _, trainer, _ = build_trainer(terrain, robot, with_priors=False)
    fresh, _ = trainer.init(1)
    fresh = jax.device_get(fresh)
    env = trainer.env
    started = init_from_policy(fresh, policy, env.obs_size, env.chi_size)
    actor = Actor(flat_trainer.env.action_size, hidden)
    wide = actor_params(started.policy, hidden)
    for _ in range(3):
        obs = rng.normal(size=size).astype(np.float32)
        obs[env.chi_size] = 0.6  # the base height
        before = policy.act_fn()(obs)
        after = actor.apply(wide, started.obs_norm(jnp.asarray(flat_to_map(obs, env.chi_size))))
        np.testing.assert_allclose(after, before, rtol=1e-4, atol=1e-5)
    # the critic and the discriminator are the fresh run's
    layers = fresh.policy["params"]
    critic = [k for k in layers if int(k.split("_")[1]) > len(hidden)]  # (no learned std here)
    assert len(critic) == len(tiny_config.ppo.critic_hidden) + 1
    for name in critic:
        np.testing.assert_array_equal(
            started.policy["params"][name]["kernel"], layers[name]["kernel"]
        )
    # an actor of other hidden layers does not fit
    other = replace(tiny_config, ppo=replace(tiny_config.ppo, actor_hidden=(8,)))
    _, small, _ = build_trainer(other, robot, with_priors=False)
    small_learner, _ = small.init(0)
    with pytest.raises(TrainError, match="its actor's layer 0 is"):
        init_from_policy(jax.device_get(small_learner), policy, env.obs_size, env.chi_size)
