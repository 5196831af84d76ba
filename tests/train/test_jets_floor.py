"""The fitted jets' throttle floor ([env] throttle_min): the throttle of an action, the idle thrust
at the floor (the published P250's steady thrust, in closed form), the resting states that
start episodes at or below idle under the floor throttle, episodes that start at idle, and the
config's checks."""

import tomllib
from dataclasses import replace

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from motionkit.core.errors import TrainError
from motionkit.jet_ident.model import Normalisation, init_variables
from motionkit.jet_ident.p250 import P250_COEFFS, steady_throttle
from motionkit.jet_ident.step import GreyBoxThrust, LSTMThrust, initial_state, thrust_next
from motionkit.train.config import EnvConfig, TrainConfig
from motionkit.train.env.jets import Jets

GREY = EnvConfig(control_hz=50.0, jet="grey_box", jet_model="unused.npz", throttle_min=15.0)
T_MAX = np.full(4, 250.0)
# the published P250's stable steady thrust (p250.steady_thrust, the root of a quadratic in
# the normalised thrust) at 0 % and at the paper's 15 % floor
IDLE_0, IDLE_15 = 16.0023, 40.4710


def grey_jets(floor: float) -> Jets:
    """The published P250 as the jets' grey box, fitted at 100 Hz, stepped at 50 Hz."""
    params = GreyBoxThrust(jnp.asarray(P250_COEFFS, jnp.float32), 0.01)
    return Jets(replace(GREY, throttle_min=floor), T_MAX, params)


def silent_lstm(delay: int = 0) -> LSTMThrust:
    """An LSTM on the published second-order P250 prior, its output layer zero: the model is
    the prior alone, whose steady states are the published ones."""
    norm = Normalisation(108.309, 65.793, 47.333, 31.483, 65.793)
    return LSTMThrust.from_variables(init_variables(8, 0, P250_COEFFS), norm, 0.01, delay)


def test_the_action_sets_the_throttle_above_the_floor() -> None:
    """u = 15 + 85 (a + 1) / 2: -1 -> 15, 0 -> 57.5, 0.5 -> 78.75, 1 -> 100 %; without a floor
    the former 50 + 50 a."""
    actions = jnp.array([-1.0, 0.0, 0.5, 1.0])
    floored, plain = grey_jets(15.0), grey_jets(0.0)
    np.testing.assert_allclose(np.asarray(floored.throttle(actions)), [15, 57.5, 78.75, 100])
    np.testing.assert_allclose(np.asarray(plain.throttle(actions)), [0, 50, 75, 100])
    assert floored.rest_action == -1.0 and floored.fitted
    # the command's share of its range above rest: the throttle above the floor
    np.testing.assert_allclose(
        np.asarray(floored.command_share(actions, jnp.zeros(4))), [0, 0.5, 0.75, 1]
    )
    # one control step (2 steps of 0.01 s) of each jet at those throttles, stepped here alone
    thrust = jnp.array([60.0, 60.0, 120.0, 200.0])
    _, got = floored.step(floored.state_at(thrust), thrust, actions)
    for j, u in enumerate([15.0, 57.5, 78.75, 100.0]):
        state, t = (jnp.zeros(()),), thrust[j]
        for _ in range(2):
            state, t = thrust_next(floored.params, state, t, jnp.asarray(u))
        assert float(got[j]) == pytest.approx(float(t), rel=1e-6)
    assert float(got[0]) < 60.0 < float(got[3])  # the floor spools down, full throttle up


def test_idle_is_the_steady_thrust_at_the_floor() -> None:
    """Jets.idle (the model run 30 s at the floor) is the closed-form steady thrust there; the
    AMP feature reads thrust above it."""
    floored, plain = grey_jets(15.0), grey_jets(0.0)
    assert floored.idle == pytest.approx(IDLE_15, abs=0.01)  # "about 40 N per engine"
    assert plain.idle == pytest.approx(IDLE_0, abs=0.01)
    # feature: (T - idle - 0.02 T_max) / T_max above idle + 5 N, else 0
    thrust = jnp.array([0.0, IDLE_15, IDLE_15 + 5.0, IDLE_15 + 30.0])
    feature = np.asarray(floored.feature(thrust))
    np.testing.assert_allclose(feature, [0.0, 0.0, 0.0, 25.0 / 250.0], atol=2e-4)


def test_resting_states_respect_the_floor() -> None:
    """The table's jets at or below idle rest at the floor throttle (the last throttles of the
    dead-time queue are 15 %); above idle at the throttle that holds the thrust (the closed
    form's steady throttle); a state between two entries is linear in them."""
    config = EnvConfig(control_hz=50.0, jet="lstm", jet_model="unused.npz", throttle_min=15.0)
    jets = Jets(config, T_MAX, silent_lstm(delay=3))
    assert jets.idle == pytest.approx(IDLE_15, abs=0.01)
    grid, c, *_, queue = jets._table  # (thrusts, c, h, p, dead-time queue)
    below = np.asarray(grid) <= jets.idle
    assert below.sum() == 11  # 0, 3.97, ..., 39.7 N: entries at or below 40.47 N
    np.testing.assert_array_equal(np.asarray(queue)[below], 15.0)
    above = np.flatnonzero(~below)
    held = steady_throttle(P250_COEFFS, np.asarray(grid)[above])
    np.testing.assert_allclose(np.asarray(queue)[above, 0], held, atol=0.05)  # 21-point curve
    # a jet resting at 19.8 N (below idle): the model warmed up at 19.8 N under 15 %
    expected = initial_state(jets.params, jnp.asarray(grid[5]), jnp.asarray(15.0))
    got = jets.state_at(jnp.full(4, grid[5]))
    for table, want in zip(got, expected, strict=True):
        np.testing.assert_allclose(np.asarray(table[0]), np.asarray(want), atol=1e-4)
    middle = jets.state_at(jnp.full(4, 0.5 * (grid[20] + grid[21])))
    np.testing.assert_allclose(np.asarray(middle[0][0]), 0.5 * np.asarray(c[20] + c[21]),
                               atol=1e-5)  # fmt: skip


def test_episodes_start_at_idle(robot, tiny_config) -> None:
    """A standing start of fitted jets is at their idle thrust (the floor's steady thrust);
    an ideal jet still starts at the low end of initial_thrust."""
    from motionkit.train.env import Env

    config = replace(
        tiny_config.env, jet="lstm", jet_model="unused.npz", throttle_min=15.0, impl="mujoco"
    )
    env = Env(robot, config, tiny_config.reward, jet_model=silent_lstm())
    pose = jax.jit(env.reset_pose)(jax.random.key(0))
    np.testing.assert_allclose(np.asarray(pose.thrust), IDLE_15, atol=0.1)
    ideal = Env(robot, replace(tiny_config.env, impl="mujoco"), tiny_config.reward)
    start = jax.jit(ideal.reset_pose)(jax.random.key(0))
    np.testing.assert_array_equal(np.asarray(start.thrust), 0.0)


@pytest.mark.parametrize("value", [-1.0, 100.0, 150.0, float("nan"), float("inf")])
def test_the_floor_is_a_share_of_the_throttle(value: float) -> None:
    with pytest.raises(TrainError, match=r"'throttle_min' should be finite and in \[0, 100\) %"):
        EnvConfig(jet="lstm", jet_model="m.npz", throttle_min=value)


def test_the_floor_needs_a_fitted_jet() -> None:
    with pytest.raises(TrainError, match="'throttle_min' needs a fitted jet"):
        EnvConfig(throttle_min=15.0)
    assert EnvConfig().throttle_min == 0.0
    text = "[env]\njet = 'lstm'\njet_model = 'm.npz'\nthrottle_min = 15\n"
    assert TrainConfig.from_dict(tomllib.loads(text)).env.throttle_min == 15.0
