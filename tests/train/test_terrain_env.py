"""The terrain scenario on both physics backends: the robot stands on its tile's pad of the
heightfield, the height map samples the terrain around it, steps stay finite; MJX and MuJoCo C
step the same heightfield (a robot on a raised block stands at the block's height in both) and
observe the same height map of the same states."""

from dataclasses import replace

import jax
import jax.numpy as jnp
import numpy as np
import pytest

pytestmark = pytest.mark.slow  # compiles MJX with heightfield collisions

BLOCK = 0.25  # m: the raised block of the hand-made course
KINDS = ("rough", "stones", "pits")


def test_terrain_reset_and_step(robot, tiny_config) -> None:
    from motionkit.train.env import HEIGHT_MAP, Env, courses

    config = replace(
        tiny_config.env, impl="jax", scenario="terrain", terrain_levels=2, terrain_kinds=KINDS
    )
    env = Env(robot, config)
    assert env.obs_size == 76 - 1 + HEIGHT_MAP[0] * HEIGHT_MAP[1]
    state = jax.jit(jax.vmap(env.reset))(jax.random.split(jax.random.key(2), 3))
    layout = courses.CourseLayout.of(config)
    for base, level, kind in zip(
        np.asarray(state.data.qpos[:, :2]), state.tile.level, state.tile.kind, strict=True
    ):
        np.testing.assert_allclose(base, courses.tile_centre(layout, level, kind), atol=1e-6)
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


def _raised(robot, tiny_config, impl: str):
    """The environment on a one-tile flat course whose middle (2 x 2 m) is raised by BLOCK."""
    from motionkit.train.env import Env, courses
    from motionkit.train.env.terrain import Terrain

    config = replace(
        tiny_config.env,
        impl=impl,
        scenario="terrain",
        terrain_levels=1,
        terrain_kinds=("flat",),
        joint_noise=0.0,
    )
    heights = courses.build_heights(courses.CourseLayout.of(config))
    middle = slice(30, 51)  # points -1.0 ... 1.0 m
    heights[middle, middle] += BLOCK
    ground = Terrain(jnp.asarray(heights, jnp.float32), datum=courses.DATUM)
    return Env(robot, config, tiny_config.reward, terrain=ground)


def test_both_backends_stand_on_the_heightfield_and_see_the_same_map(robot, tiny_config) -> None:
    """MuJoCo C's model holds the heightfield too: from the same start on the raised block,
    both backends stand the base BLOCK above the standing height (0.611 m), 0.5 s later
    within 2 mm of each other in height; on the same states, anywhere on the block or off its
    edges, their height maps agree to float rounding."""
    from motionkit.train.env.mjx import mjx
    from motionkit.train.env.mujoco import BatchPhysics, stepper

    mjx_env = _raised(robot, tiny_config, "jax")
    mujoco_env = _raised(robot, tiny_config, "mujoco")
    assert mujoco_env.mj_model.nhfield == 1 and mjx_env.mj_model.nhfield == 1
    keys = jax.random.split(jax.random.key(4), 4)
    state_mjx = jax.jit(jax.vmap(mjx_env.reset))(keys)
    physics = BatchPhysics(mujoco_env, 4, threads=1)
    state = physics.reset(keys)
    np.testing.assert_allclose(state.data.qpos, state_mjx.data.qpos, atol=1e-6)
    np.testing.assert_allclose(state.data.qpos[:, 2], 0.611 + BLOCK, atol=1e-3)
    # the same states: moved about the block's edges and turned
    rng = np.random.default_rng(0)
    qpos = np.asarray(state_mjx.data.qpos).copy()
    qpos[:, :2] = rng.uniform(-1.6, 1.6, (4, 2))
    yaw = rng.uniform(-np.pi, np.pi, 4)
    qpos[:, 3:7] = np.stack([np.cos(yaw / 2), 0 * yaw, 0 * yaw, np.sin(yaw / 2)], axis=1)
    data_mjx = jax.vmap(lambda d: mjx.kinematics(mjx_env.mx, d))(
        state_mjx.data.replace(qpos=jnp.asarray(qpos, jnp.float32))
    )
    data = physics.place(np.arange(4), qpos, np.zeros((4, mujoco_env.mj_model.nv)))
    thrust, target = jnp.zeros((4, 4)), jnp.asarray(qpos[:, :3], jnp.float32)
    maps_mjx = jax.vmap(mjx_env.observe)(data_mjx, thrust, target)[:, -66:-3]
    maps = jax.vmap(mujoco_env.observe)(data, thrust, target)[:, -66:-3]
    np.testing.assert_allclose(maps, maps_mjx, atol=1e-5)
    assert np.ptp(np.asarray(maps), axis=1).max() == pytest.approx(BLOCK, abs=1e-5)
    # standing on the block, both backends
    step_mjx, step = jax.jit(jax.vmap(mjx_env.step)), stepper(mujoco_env, [physics])
    state = physics.reset(keys)
    rest = jnp.tile(mjx_env.rest_action, (4, 1))
    for _ in range(30):
        state_mjx, info_mjx = step_mjx(state_mjx, rest)
        state, info = step(state, rest)
    assert not np.asarray(info.done).any() and not np.asarray(info_mjx.done).any()
    for base in (state.data.qpos[:, 2], state_mjx.data.qpos[:, 2]):
        np.testing.assert_allclose(base, 0.61 + BLOCK, atol=0.02)
    # heights to 2 mm; the heightfield's contacts (MJX's prisms, MuJoCo C's own) let the base
    # drift apart sideways (measured: 2.0 cm after 0.5 s)
    np.testing.assert_allclose(state.data.qpos[:, 2], state_mjx.data.qpos[:, 2], atol=2e-3)
    np.testing.assert_allclose(state.data.qpos[:, :2], state_mjx.data.qpos[:, :2], atol=0.03)
