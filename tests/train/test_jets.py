"""The environment's jets through the jet_ident interface: the ideal jet integrates the thrust
rate or approaches its set point, the LSTM is stepped at about its own rate within a control
step."""

from dataclasses import replace

import jax.numpy as jnp
import numpy as np
import pytest

from motionkit.core.errors import TrainError


def test_ideal_jet_integrates_the_rate(env) -> None:
    class Held:
        jet = ()
        thrust = jnp.array([0.0, 100.0, 249.0, 10.0])

    _, thrust = env._jets(Held, jnp.array([1.0, -0.5, 1.0, -1.0]))
    rate, dt = env.config.thrust_rate_max, env.config.control_dt
    expected = np.clip([rate * dt, 100 - 0.5 * rate * dt, 249 + rate * dt, 10 - rate * dt], 0, 250)
    np.testing.assert_allclose(np.asarray(thrust), expected, rtol=1e-6)


def test_ideal_jet_approaches_its_set_point(tiny_config) -> None:
    """jet_action 'thrust': action a sets (a + 1) / 2 T_max, reached at up to the rate limit
    (300 N/s at 30 Hz: 10 N per step); the rest action (-1) sets 0 N."""
    from motionkit.jet_ident.step import IdealThrust
    from motionkit.train.env.jets import Jets

    config = replace(tiny_config.env, jet_action="thrust", control_hz=30.0)
    jets = Jets(config, np.full(4, 250.0), None)
    assert isinstance(jets.params, IdealThrust) and jets.rest_action == -1.0
    thrust = jnp.array([0.0, 100.0, 120.0, 20.0])
    action = jnp.array([-0.12, -0.2, -0.1, -1.0])  # set points 110, 100, 112.5, 0 N
    _, got = jets.step((), thrust, action)
    np.testing.assert_allclose(np.asarray(got), [10.0, 100.0, 112.5, 10.0], atol=1e-4)
    _, got = jets.step((), got, action)
    np.testing.assert_allclose(np.asarray(got), [20.0, 100.0, 112.5, 0.0], atol=1e-4)


def test_lstm_jet_steps_the_fitted_model(robot, tiny_config) -> None:
    from motionkit.jet_ident.model import Normalisation, init_variables
    from motionkit.jet_ident.step import LSTMThrust, initial_state, thrust_next
    from motionkit.train.env import Env

    params = LSTMThrust.from_variables(
        init_variables(8, 0), Normalisation(100.0, 60.0, 50.0, 30.0, 60.0), 0.01
    )
    config = replace(tiny_config.env, jet="lstm", jet_model="unused.npz")
    env = Env(robot, config, jet_model=params)
    assert env.jets.steps == 2  # 1/60 s in two steps of 1/120 s (the model was fitted at 100 Hz)

    class Held:
        jet = env.jets.state_at(jnp.zeros(4))
        thrust = jnp.zeros(4)

    _, thrust = env._jets(Held, jnp.array([1.0, 0.0, -1.0, 0.5]))
    one = params.replace(dt=1 / 120)
    for j, a in enumerate([1.0, 0.0, -1.0, 0.5]):
        state = initial_state(one, jnp.zeros(()), jnp.zeros(()))
        t = jnp.zeros(())
        for _ in range(2):
            state, t = thrust_next(one, state, t, jnp.asarray(50.0 + 50.0 * a))
        assert float(thrust[j]) == pytest.approx(float(np.clip(t, 0, 250)), abs=1e-4)


def test_lstm_jet_needs_a_model_file(tiny_config) -> None:
    with pytest.raises(TrainError, match="jet_model"):
        replace(tiny_config.env, jet="lstm")
