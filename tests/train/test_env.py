"""The MJX environment on each MJX backend (JAX; MuJoCo Warp where an NVIDIA GPU and warp are
present): jitted batch reset/step shapes, no NaN, observation layout, falls, time limits,
waypoint hits and auto-reset; asking for warp where it is missing is a clear error."""

from dataclasses import replace

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from motionkit.core.errors import TrainError
from motionkit.train.env import Env
from motionkit.train.env import mjx as mjx_module
from motionkit.train.env.mjx import warp_missing

BATCH = 4
slow = pytest.mark.slow  # compiles MJX (about a minute on a 2-core CPU)
WARP = pytest.param(
    "warp",
    marks=pytest.mark.skipif(
        warp_missing() is not None, reason=f"MuJoCo Warp needs {warp_missing()}"
    ),
)


@pytest.fixture(scope="module", params=["jax", WARP])
def impl(request: pytest.FixtureRequest) -> str:
    return request.param


@pytest.fixture(scope="module")
def impl_env(impl: str, env, robot, tiny_config) -> Env:
    if impl == "jax":
        return env  # the session's (compiled once for every test module)
    config = replace(tiny_config.env, impl=impl)
    return Env(robot, config, tiny_config.reward, worlds=BATCH)


@pytest.fixture(scope="module")
def impl_fns(impl: str, impl_env: Env, batch_fns):
    if impl == "jax":
        return batch_fns
    return jax.jit(jax.vmap(impl_env.reset)), jax.jit(jax.vmap(impl_env.step))


@pytest.fixture(scope="module")
def started(impl_fns):
    reset, _ = impl_fns
    return reset(jax.random.split(jax.random.key(0), BATCH))


def test_warp_where_missing_is_a_clear_error(robot, tiny_config) -> None:
    missing = warp_missing()
    if missing is None:
        pytest.skip("warp and an NVIDIA GPU are present")
    config = replace(tiny_config.env, impl="warp")
    with pytest.raises(TrainError, match=r"^\[env\] impl = 'warp' needs ") as error:
        Env(robot, config, tiny_config.reward)
    assert missing in str(error.value)


def test_warp_missing_names_what_is_missing(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(mjx_module, "_cuda_devices", lambda: [])
    monkeypatch.setattr(mjx_module.mjx_warp, "WARP_INSTALLED", False)
    both = warp_missing()
    assert both.startswith("NVIDIA's warp-lang package (pip install 'motionkit[warp]') and ")
    assert "an NVIDIA GPU with JAX's CUDA plugin (JAX sees cpu)" in both
    monkeypatch.setattr(mjx_module, "_cuda_devices", lambda: ["cuda:0"])
    assert warp_missing() == "NVIDIA's warp-lang package (pip install 'motionkit[warp]')"
    monkeypatch.setattr(mjx_module.mjx_warp, "WARP_INSTALLED", True)
    monkeypatch.setattr(mjx_module.importlib.util, "find_spec", lambda name: object())
    assert warp_missing() is None
    monkeypatch.setattr(mjx_module, "_cuda_devices", lambda: [])
    assert warp_missing() == "an NVIDIA GPU with JAX's CUDA plugin (JAX sees cpu)"


def test_impl_is_checked(tiny_config) -> None:
    with pytest.raises(
        TrainError, match="'impl' should be one of 'auto', 'jax', 'warp', 'mujoco', got 'cpp'"
    ):
        replace(tiny_config.env, impl="cpp")


@slow
def test_reset_shapes_and_layout(impl_env, started) -> None:
    assert impl_env.obs_size == 76 and impl_env.chi_size == 72 and impl_env.action_size == 27
    assert started.obs.shape == (BATCH, 76) and started.chi.shape == (BATCH, 72)
    obs = np.asarray(started.obs)
    assert np.all(np.isfinite(obs))
    base = np.asarray(started.data.qpos[:, :3])
    # the standing robot faces the world's +x at the identity orientation: obs[:4] = identity
    np.testing.assert_allclose(obs[:, :4], [[1, 0, 0, 0]] * BATCH, atol=1e-6)
    # flat ground: a single base height; then the waypoint relative to the base
    np.testing.assert_allclose(obs[:, -4], base[:, 2], atol=1e-6)
    np.testing.assert_allclose(obs[:, -3:], np.asarray(started.target) - base, atol=1e-5)
    distance = np.linalg.norm(np.asarray(started.target) - base, axis=1)
    assert np.all((distance >= 0.7 - 1e-4) & (distance <= 2.0 + 1e-4))


@slow
def test_steps_without_nan(impl_env, impl_fns, started) -> None:
    _, step = impl_fns
    state = started
    rng = np.random.default_rng(0)
    for _ in range(10):
        action = jnp.asarray(rng.uniform(-1, 1, (BATCH, impl_env.action_size)), jnp.float32)
        state, info = step(state, action)
    for leaf in jax.tree.leaves((state.obs, state.chi, state.data.qpos, info)):
        assert np.all(np.isfinite(np.asarray(leaf, dtype=float)))
    assert info.task_reward.shape == (BATCH,) and info.done.shape == (BATCH,)
    assert int(state.steps.max()) <= 10
    # the ideal jets integrate the thrust rate within [0, T_max]
    assert np.all((np.asarray(state.thrust) >= 0) & (np.asarray(state.thrust) <= 250.0))


@slow
def test_standing_still_is_stable(impl_env, impl_fns, started) -> None:
    _, step = impl_fns
    state = started
    for _ in range(30):  # half a second at 60 Hz, the rest action: stand under PD
        state, info = step(state, jnp.tile(impl_env.rest_action, (BATCH, 1)))
    assert not np.any(np.asarray(info.done))
    np.testing.assert_allclose(np.asarray(state.data.qpos[:, 2]), 0.61, atol=0.02)
    assert np.all(np.asarray(info.feet_down)) and not np.any(np.asarray(info.airborne))


@slow
def test_fall_time_limit_and_waypoint_hit(impl_env, impl_fns, started) -> None:
    _, step = impl_fns
    qpos = started.data.qpos.at[0, 2].set(0.3)  # env 0: base too low -> a fall
    steps = started.steps.at[1].set(impl_env.config.max_steps - 1)  # env 1: last step
    target = started.target.at[2].set(started.data.qpos[2, :3])  # env 2: on its waypoint
    qpos = qpos.at[3, 2].add(0.5)  # env 3: lifted 0.5 m, on an air waypoint (1.1 m up)
    target = target.at[3].set(qpos[3, :3])
    state = started.replace(data=started.data.replace(qpos=qpos), steps=steps, target=target)
    after, info = step(state, jnp.tile(impl_env.rest_action, (BATCH, 1)))
    done, truncated, hit = map(np.asarray, (info.done, info.truncated, info.hit))
    np.testing.assert_array_equal(done, [True, True, False, False])
    np.testing.assert_array_equal(truncated, [False, True, False, False])
    np.testing.assert_array_equal(hit, [False, False, True, True])
    # env 3's hit is an air one, after one step airborne
    np.testing.assert_array_equal(np.asarray(info.air_target)[2:], [False, True])
    np.testing.assert_array_equal(np.asarray(info.episode_air_reached)[2:], [0, 1])
    np.testing.assert_array_equal(np.asarray(info.episode_longest_flight)[2:], [0, 1])
    assert int(after.flight_steps[3]) == 1 and int(after.air_reached[3]) == 1
    # ended episodes start again (auto-reset); the final observation is the ended one's
    np.testing.assert_array_equal(np.asarray(after.steps), [0, 0, 1, 1])
    assert float(info.final_obs[0, -4]) < 0.4 and float(after.obs[0, -4]) > 0.6
    assert int(info.episode_steps[1]) == impl_env.config.max_steps
    # the hit counts and a new waypoint 0.7-2.0 m from the reached one appears
    assert int(after.reached[2]) == 1 and int(info.episode_reached[2]) == 1
    jump = np.linalg.norm(np.asarray(after.target[2] - target[2]))
    assert 0.7 - 1e-4 <= jump <= 2.0 + 1e-4


def test_the_swing_term_reads_each_soles_lift_and_speed(impl_env, started) -> None:
    env, data = impl_env, jax.tree.map(lambda x: x[0], started.data)
    left, right = np.asarray(env.sole_sites)[:2]
    config = env.reward_config
    lift = float(env.sole_clearance(data)[0])
    # the left sole rises to 3/4 of the swing height (6 cm: off the ground) and moves at half
    # v_desired; the right stays down and still: 0.75 * 0.5
    step = 0.5 * config.v_desired * env.config.control_dt
    moved = data.site_xpos.at[left, 2].add(0.75 * config.swing_height - lift)
    moved = moved.at[left, 0].add(step)
    after = data.replace(site_xpos=moved)
    down = env.feet_down(after)
    assert not bool(down[0]) and bool(down[1])
    clearance = env.sole_clearance(after)
    ground = jnp.array([1.0, 0.0, env.config.ground_height])  # the tiny scenario is flat
    assert float(env._swing(data, after, clearance, ground)) == pytest.approx(0.375, rel=1e-4)
    # the same step with the right sole lifted too (no foot down) earns nothing
    both = after.replace(site_xpos=moved.at[right, 2].add(0.2))
    assert float(env._swing(data, both, env.sole_clearance(both), ground)) == 0.0
    # nor does the same step on the way to an air waypoint (1.2 m up)
    air = ground.at[2].set(env.config.ground_height + 0.6)
    assert float(env._swing(data, after, clearance, air)) == 0.0


def test_the_thrust_limit_caps_the_ideal_jets(robot, tiny_config) -> None:
    """The thrust set point at full (T_max) approached at 300 N/s for 0.2 s: 60 N a jet free,
    37.5 N with thrust_limit 0.15 (0.15 x 250 N), none with 0; a fitted jet refuses a limit."""
    from motionkit.train.config import EnvConfig

    def thrust_after(limit: float) -> np.ndarray:
        config = replace(tiny_config.env, impl="jax", jet_action="thrust", thrust_limit=limit)
        env = Env(robot, config, tiny_config.reward)
        state = env.reset(jax.random.key(0))
        full = jnp.ones(env.action_size)
        for _ in range(round(0.2 * config.control_hz)):
            _, jet, thrust = env.control(state, full)
            state = state.replace(thrust=thrust, jet=jet)
        return np.asarray(thrust)

    np.testing.assert_allclose(thrust_after(1.0), 60.0, rtol=1e-5)
    np.testing.assert_allclose(thrust_after(0.15), 37.5, rtol=1e-5)
    np.testing.assert_allclose(thrust_after(0.0), 0.0)
    with pytest.raises(TrainError, match="'thrust_limit' needs jet = 'ideal'"):
        EnvConfig(jet="lstm", jet_model="m.npz", thrust_limit=0.5)
