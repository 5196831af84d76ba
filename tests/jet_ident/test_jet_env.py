"""The trainer's jets on the fitted models: the grey box of jet_model as a jittable step, and
an LSTM on a second-order prior (a state of three parts), through motionkit.train.env.jets."""

import jax.numpy as jnp
import numpy as np
import pytest

from motionkit.jet_ident.model import Normalisation, init_variables
from motionkit.jet_ident.p250 import P250_COEFFS, steady_thrust
from motionkit.jet_ident.step import GreyBoxThrust, LSTMThrust, thrust_next
from motionkit.train.config import EnvConfig
from motionkit.train.env.jets import Jets

CONFIG = EnvConfig(control_hz=60.0, jet="grey_box", jet_model="unused.npz")


def test_grey_box_jets_idle_and_step() -> None:
    params = GreyBoxThrust(jnp.asarray(P250_COEFFS, jnp.float32), 0.01)
    jets = Jets(CONFIG, np.full(4, 250.0), params)
    assert jets.steps == 2 and jets.params.dt == pytest.approx(1 / 120)
    assert jets.idle == pytest.approx(float(steady_thrust(P250_COEFFS, 0.0)), abs=0.05)
    assert jets.rest_action == -1.0
    thrust = jnp.array([20.0, 60.0, 120.0, 200.0])
    state = jets.state_at(thrust)  # at rest: Tdot = 0
    np.testing.assert_array_equal(np.asarray(state[0]), 0.0)
    action = jnp.array([1.0, 0.0, -1.0, 0.5])
    _, got = jets.step(state, thrust, action)
    for j in range(4):
        one, t = (jnp.zeros(()),), thrust[j]
        for _ in range(2):
            one, t = thrust_next(jets.params, one, t, 50.0 + 50.0 * action[j])
        assert float(got[j]) == pytest.approx(float(t), rel=1e-6)
    assert float(got[0]) > 20.0 and float(got[2]) < 120.0  # full throttle up, idle down


def test_lstm_on_a_second_order_prior_rests_and_steps() -> None:
    variables = init_variables(8, 0, P250_COEFFS)
    norm = Normalisation(100, 60, 50, 30, 60)
    params = LSTMThrust.from_variables(variables, norm, 0.01, delay=6)
    config = EnvConfig(control_hz=60.0, jet="lstm", jet_model="unused.npz")
    jets = Jets(config, np.full(4, 250.0), params)
    assert jets.params.delay == 7  # 60 ms at 1/120 s
    state = jets.state_at(jnp.array([30.0, 80.0, 150.0, 210.0]))
    assert [s.shape for s in state] == [(4, 8), (4, 8), (4,), (4, 7)]
    # near zero, the LSTM silent: the model is about the published one
    assert jets.idle == pytest.approx(float(steady_thrust(P250_COEFFS, 0.0)), abs=5.0)
    new_state, thrust = jets.step(state, jnp.array([30.0, 80.0, 150.0, 210.0]), jnp.zeros(4))
    assert [s.shape for s in new_state] == [(4, 8), (4, 8), (4,), (4, 7)]
    assert thrust.shape == (4,)
