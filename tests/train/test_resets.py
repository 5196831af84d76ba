"""Resets from the motion priors (reference state initialisation): a reset drawn from a prior
frame has that frame's AMP features and observation, starts above the spawn point, and an
airborne start gets an air waypoint; the jets start resting at the frame's thrust."""

from dataclasses import replace

import jax
import jax.numpy as jnp
import numpy as np
import pytest

pytestmark = pytest.mark.slow  # compiles the batched reset (MJX kinematics)

BATCH = 64


@pytest.fixture(scope="module")
def standing_clip(robot, env, tmp_path_factory: pytest.TempPathFactory):
    """Two seconds of the standing robot, soles on the ground (a grounded prior)."""
    from motionkit.dataset import write
    from motionkit.dataset.synthetic import synthetic_trajectory

    clip = synthetic_trajectory(robot, 2.0, 60.0, seed=5)
    frames = clip.frames
    stand = np.asarray(env.stand.qpos)
    clip = replace(
        clip,
        base_position=np.tile(stand[:3], (frames, 1)),
        base_orientation=np.tile(stand[3:7], (frames, 1)),
        joint_positions=np.tile(stand[7:], (frames, 1)),
        joint_velocities=np.zeros((frames, env.num_joints)),
        base_linear_velocity=np.zeros((frames, 3)),
        base_angular_velocity=np.zeros((frames, 3)),
    )
    return write(tmp_path_factory.mktemp("stand") / "stand.mcap", clip, robot)


@pytest.fixture(scope="module")
def prior_env(robot, tiny_config, prior_files, standing_clip):
    from motionkit.train.config import PriorConfig
    from motionkit.train.env import Env
    from motionkit.train.priors import load_priors

    priors = {
        "flight": PriorConfig((str(prior_files["flight"]),)),  # 110 N per jet, airborne
        "stand": PriorConfig((str(standing_clip),)),
    }
    prior, summary = load_priors(priors, robot, tiny_config.env.control_hz)
    assert summary["flight"]["airborne_share"] > 0.9 and summary["stand"]["airborne_share"] == 0
    config = replace(tiny_config.env, impl="jax", reset_from_prior=1.0, air_probability=0.0)
    return Env(robot, config, tiny_config.reward, prior=prior)


@pytest.fixture(scope="module")
def resets(prior_env):
    return jax.jit(jax.vmap(prior_env.reset))(jax.random.split(jax.random.key(0), BATCH))


def test_prior_resets_have_the_frames_features_and_observation(prior_env, resets) -> None:
    env = prior_env
    origin = np.asarray(resets.origin)
    assert np.all(origin >= 0) and len(set(origin.tolist())) > BATCH // 2  # many frames drawn
    expected = np.asarray(env.prior.current)[origin]  # the dataset's features (pinocchio)
    np.testing.assert_allclose(np.asarray(resets.chi), expected, atol=1e-5)
    states = env.prior.states
    thrust = np.asarray(states.thrust)[origin]
    qpos = np.asarray(resets.data.qpos)
    np.testing.assert_allclose(qpos[:, :2], 0.0, atol=1e-6)  # above the spawn point
    np.testing.assert_allclose(qpos[:, 2], np.asarray(states.qpos)[origin, 2], atol=1e-6)
    # the observation from the dataset's features: orientation and velocities, joints relative
    # to standing, joint velocities, effectors, thrust / T_max, base height, waypoint
    joints = env.num_joints
    obs = np.asarray(resets.obs)
    np.testing.assert_allclose(obs[:, :10], expected[:, :10], atol=1e-5)
    default = np.asarray(env.default_q)
    np.testing.assert_allclose(obs[:, 10 : 10 + joints], expected[:, 10 : 10 + joints] - default,
                               atol=1e-5)  # fmt: skip
    np.testing.assert_allclose(obs[:, 10 + joints : -8], expected[:, 10 + joints : -4], atol=1e-5)
    np.testing.assert_allclose(obs[:, -8:-4], thrust / 250.0, atol=1e-6)
    np.testing.assert_allclose(obs[:, -4], qpos[:, 2], atol=1e-6)
    distance = np.linalg.norm(np.asarray(resets.target) - qpos[:, :3], axis=1)
    np.testing.assert_allclose(np.linalg.norm(obs[:, -3:], axis=1), distance, atol=1e-5)
    np.testing.assert_allclose(np.asarray(resets.thrust), thrust, atol=1e-6)


def test_airborne_starts_get_air_waypoints(prior_env, resets) -> None:
    airborne = np.asarray(prior_env.prior.states.airborne)[np.asarray(resets.origin)]
    assert 0 < airborne.sum() < BATCH  # both clips were drawn
    lift = np.asarray(resets.target[:, 2])  # flat ground at 0
    low, high = prior_env.config.air_height
    assert np.all((lift[airborne] >= low - 1e-6) & (lift[airborne] <= high + 1e-6))
    # air_probability 0: a start on the ground gets a ground waypoint
    np.testing.assert_allclose(lift[~airborne], prior_env.config.ground_height, atol=1e-6)


def test_prior_share_picks_standing_or_prior_starts(prior_env) -> None:
    keys = jax.random.split(jax.random.key(1), BATCH)
    standing = jax.jit(jax.vmap(lambda k: prior_env.reset(k, 0.0, 0.0)))(keys)
    assert np.all(np.asarray(standing.origin) == -1)
    np.testing.assert_allclose(
        np.asarray(standing.data.qpos[:, 2]), float(prior_env.stand.qpos[2]), atol=1e-6
    )
    np.testing.assert_array_equal(np.asarray(standing.thrust), 0.0)
    mixed = jax.jit(jax.vmap(lambda k: prior_env.reset(k, 0.0, 0.5)))(keys)
    share = np.mean(np.asarray(mixed.origin) >= 0)
    assert 0.3 <= share <= 0.7  # 64 draws at 0.5


def test_lstm_jets_rest_at_the_start_thrust(tiny_config) -> None:
    from motionkit.jet_ident.model import Normalisation, init_variables
    from motionkit.jet_ident.step import LSTMThrust, initial_state, thrust_next
    from motionkit.train.env.jets import TABLE_SIZE, THROTTLES, Jets

    params = LSTMThrust.from_variables(
        init_variables(8, 0), Normalisation(100.0, 60.0, 50.0, 30.0, 60.0), 0.01
    )
    config = replace(tiny_config.env, jet="lstm", jet_model="unused.npz")
    jets = Jets(config, np.full(4, 250.0), params)
    one = jets.params  # stepped at 1/120 s
    # idle: where the model settles at 0 % throttle after 30 s, stepped here independently
    state, thrust = (jnp.zeros(8), jnp.zeros(8)), jnp.zeros(())
    for _ in range(3600):
        state, thrust = thrust_next(one, state, thrust, jnp.zeros(()))
        thrust = jnp.clip(thrust, 0.0, 250.0)
    assert jets.idle == pytest.approx(max(float(thrust), 0.0), abs=1e-3)
    # at a tabulated thrust the state is the LSTM warmed up at it under the holding throttle,
    # between two it is linear
    grid, c, _ = jets._table
    k = 20
    steady = np.maximum.accumulate(jets._steady_thrust(THROTTLES))
    u = np.interp(float(grid[k]), steady, THROTTLES)
    expected = initial_state(one, grid[k], jnp.asarray(u, jnp.float32))
    got = jets.state_at(jnp.full(4, grid[k]))
    np.testing.assert_allclose(np.asarray(got[0][0]), np.asarray(expected[0]), atol=1e-5)
    middle = jets.state_at(jnp.full(4, 0.5 * (grid[k] + grid[k + 1])))
    np.testing.assert_allclose(np.asarray(middle[0][0]), 0.5 * np.asarray(c[k] + c[k + 1]),
                               atol=1e-5)  # fmt: skip
    assert len(grid) == TABLE_SIZE and jets.rest_action == -1.0
    # the AMP thrust feature: 0 up to 5 N (2 % of T_max) above idle, (T - idle - 5) / T_max
    feature = jets.feature(jnp.array([jets.idle, jets.idle + 5.0, jets.idle + 25.0, 250.0]))
    np.testing.assert_allclose(
        np.asarray(feature), [0.0, 0.0, 0.08, (245.0 - jets.idle) / 250.0], atol=1e-6
    )
    assert float(jets.feature(jnp.zeros(4)).max()) == 0.0  # a jet that is off
