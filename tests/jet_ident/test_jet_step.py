"""The simulator's thrust_next against the training-time flax step; jit, vmap, ideal model."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from motionkit.jet_ident.model import Normalisation, init_variables, lstm_step, rollout, zero_carry
from motionkit.jet_ident.step import IdealThrust, LSTMThrust, free_run, initial_state, thrust_next

HIDDEN = 6
NORM = Normalisation(100.0, 60.0, 45.0, 30.0, 60.0)


@pytest.fixture(scope="module")
def variables() -> dict:
    variables = init_variables(HIDDEN, 3)
    # A head of ordinary size, so that the thrust moves noticeably.
    head = variables["params"]["head"]
    kernel = jax.random.normal(jax.random.key(1), head["kernel"].shape)
    return {"params": {**variables["params"], "head": {**head, "kernel": kernel}}}


def test_thrust_next_equals_the_training_step(variables: dict) -> None:
    params = LSTMThrust.from_variables(variables, NORM, 0.01)
    rng = np.random.default_rng(0)
    carry = zero_carry(HIDDEN)
    state = (jnp.zeros(HIDDEN), jnp.zeros(HIDDEN))
    thrust = jnp.float32(40.0)
    for u in rng.uniform(0, 100, 30):
        carry, expected = lstm_step(HIDDEN, variables, NORM, 0.01, carry, thrust, jnp.float32(u))
        state, got = thrust_next(params, state, thrust, jnp.float32(u))
        np.testing.assert_allclose(got, expected, rtol=1e-5, atol=1e-4)
        np.testing.assert_allclose(state[1], carry[1], atol=1e-5)
        thrust = expected
    assert abs(float(thrust) - 40.0) > 1.0  # the check was not trivial


def test_jit_and_vmap_over_environments(variables: dict) -> None:
    params = LSTMThrust.from_variables(variables, NORM, 0.01)
    thrust = jnp.linspace(10, 220, 64)
    throttle = jnp.linspace(0, 100, 64)
    states = jax.vmap(lambda t, u: initial_state(params, t, u))(thrust, throttle)
    batched = jax.jit(jax.vmap(thrust_next, in_axes=(None, 0, 0, 0)))
    new_states, new_thrust = batched(params, states, thrust, throttle)
    assert new_thrust.shape == (64,) and new_states[0].shape == (64, HIDDEN)
    for i in (0, 17, 63):
        state = initial_state(params, thrust[i], throttle[i])
        _, one = thrust_next(params, state, thrust[i], throttle[i])
        np.testing.assert_allclose(new_thrust[i], one, rtol=1e-5)


def test_free_run_equals_the_training_rollout(variables: dict) -> None:
    params = LSTMThrust.from_variables(variables, NORM, 0.01)
    rng = np.random.default_rng(1)
    thrust = jnp.asarray(100 + 20 * rng.standard_normal(80), jnp.float32)
    throttle = jnp.asarray(rng.uniform(0, 100, 80), jnp.float32)
    expected = rollout(HIDDEN, variables, NORM, 0.01, thrust[None], throttle[None], 10)[0]
    got = free_run(params, thrust, throttle, 10)
    assert got.shape == (70,)
    np.testing.assert_allclose(got, expected, rtol=1e-5, atol=1e-3)


def test_ideal_model_integrates_the_thrust_rate() -> None:
    ideal = IdealThrust(dt=0.01, t_max=250.0, rate_max=300.0)
    state = initial_state(ideal, 100.0, 0.0)
    assert state == ()
    _, up = thrust_next(ideal, state, jnp.float32(100.0), jnp.float32(50.0))
    assert float(up) == pytest.approx(100.5)
    _, capped = thrust_next(ideal, state, jnp.float32(100.0), jnp.float32(1000.0))
    assert float(capped) == pytest.approx(103.0)  # rate clipped at 300 N/s
    _, floor = thrust_next(ideal, state, jnp.float32(1.0), jnp.float32(-300.0))
    assert float(floor) == 0.0
    batched = jax.jit(jax.vmap(thrust_next, in_axes=(None, None, 0, 0)))
    _, out = batched(ideal, (), jnp.array([249.0, 10.0]), jnp.array([200.0, -100.0]))
    np.testing.assert_allclose(out, [250.0, 9.0])
