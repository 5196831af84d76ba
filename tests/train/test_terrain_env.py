"""The terrain scenario in MJX: the robot stands on a spawn pad of the heightfield, the height
map samples the terrain around it, and steps stay finite."""

from dataclasses import replace

import jax
import jax.numpy as jnp
import numpy as np
import pytest

pytestmark = pytest.mark.slow  # compiles MJX with heightfield collisions


def test_terrain_reset_and_step(robot, tiny_config) -> None:
    from motionkit.train.env import HEIGHT_MAP, Env, terrain

    env = Env(robot, replace(tiny_config.env, impl="jax", scenario="terrain", terrain_size=8.0))
    assert env.obs_size == 76 - 1 + HEIGHT_MAP[0] * HEIGHT_MAP[1]
    state = jax.jit(jax.vmap(env.reset))(jax.random.split(jax.random.key(2), 3))
    spawns = {tuple(p) for p in np.round(terrain.tile_centres(8.0), 3)}
    for base in np.asarray(state.data.qpos[:, :2]):
        assert tuple(np.round(base, 3)) in spawns
    heights = np.asarray(state.obs[:, -66:-3])
    # the pads are flat: the middle of the map is the base height below the base
    centre = heights.reshape(3, *HEIGHT_MAP)[:, 3, 4]
    np.testing.assert_allclose(centre, -np.asarray(state.data.qpos[:, 2]), atol=1e-5)
    # the map reaches the tiles' rough ground, stones or pits 1.2 m away
    assert np.ptp(heights, axis=1).max() > 0.01
    step = jax.jit(jax.vmap(env.step))
    for _ in range(5):
        state, info = step(state, jnp.tile(env.rest_action, (3, 1)))
    assert np.all(np.isfinite(np.asarray(state.obs))) and not np.any(np.asarray(info.done))
    np.testing.assert_allclose(np.asarray(state.data.qpos[:, 2]), 0.61, atol=0.02)
