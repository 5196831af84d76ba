"""The simulator's thrust_next against the training-time flax step (with and without a prior),
the grey box's step against the numpy baseline; jit, vmap, ideal model."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from motionkit.jet_ident.baselines import GreyBox
from motionkit.jet_ident.model import Normalisation, init_variables, lstm_step, rollout, zero_carry
from motionkit.jet_ident.p250 import P250_COEFFS, thrust_acceleration
from motionkit.jet_ident.step import (
    GreyBoxThrust,
    IdealThrust,
    LSTMThrust,
    free_run,
    free_run_jit,
    initial_state,
    thrust_next,
)

FIRST = np.array([0.05, -0.9, 0.8, 0.02, -0.03, 0.01])  # a first-order prior (model.py)

HIDDEN = 6
NORM = Normalisation(100.0, 60.0, 45.0, 30.0, 60.0)


@pytest.fixture(scope="module")
def variables() -> dict:
    variables = init_variables(HIDDEN, 3)
    # A head of ordinary size, so that the thrust moves noticeably.
    head = variables["params"]["head"]
    kernel = jax.random.normal(jax.random.key(1), head["kernel"].shape)
    return {"params": {**variables["params"], "head": {**head, "kernel": kernel}}}


@pytest.mark.parametrize("prior", [None, FIRST, P250_COEFFS])
def test_thrust_next_equals_the_training_step(variables: dict, prior: np.ndarray | None) -> None:
    if prior is not None:
        variables = {**variables, "prior": jnp.asarray(prior, jnp.float32)}
    params = LSTMThrust.from_variables(variables, NORM, 0.01)
    rng = np.random.default_rng(0)
    carry = zero_carry(HIDDEN, prior=variables.get("prior"))
    state = params.zero_state()
    assert len(state) == len(carry) == (3 if prior is P250_COEFFS else 2)
    thrust = jnp.float32(40.0)
    for u in rng.uniform(0, 100, 30):
        carry, expected = lstm_step(HIDDEN, variables, NORM, 0.01, carry, thrust, jnp.float32(u))
        state, got = thrust_next(params, state, thrust, jnp.float32(u))
        np.testing.assert_allclose(got, expected, rtol=1e-5, atol=1e-4)
        for a, b in zip(state, carry, strict=True):
            np.testing.assert_allclose(a, b, rtol=1e-5, atol=1e-4)
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


@pytest.mark.parametrize("prior", [None, FIRST, P250_COEFFS])
def test_free_run_equals_the_training_rollout(variables: dict, prior: np.ndarray | None) -> None:
    if prior is not None:
        variables = {**variables, "prior": jnp.asarray(prior, jnp.float32)}
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


def _silent(variables: dict, prior: np.ndarray) -> LSTMThrust:
    """A model whose LSTM adds nothing: the prior alone."""
    head = {"kernel": jnp.zeros((HIDDEN, 1)), "bias": jnp.zeros(1)}
    params = {**variables["params"], "head": head}
    return LSTMThrust.from_variables({"params": params, "prior": jnp.asarray(prior)}, NORM, 0.01)


def test_first_order_prior_by_hand(variables: dict) -> None:
    # T = 130 N, u = 60 %: t = (130 - 100) / 60 = 0.5, v = (60 - 45) / 30 = 0.5;
    # q.(1, t, v, t^2, t v, v^2) = 0.05 - 0.45 + 0.4 + 0.005 - 0.0075 + 0.0025 = 0.0;
    # at T = 100 N (t = 0): 0.05 + 0.4 + 0.0025 = 0.4525, times 60 N/s: 27.15 N/s
    params = _silent(variables, FIRST)
    state = params.zero_state()
    _, same = thrust_next(params, state, jnp.float32(130.0), jnp.float32(60.0))
    assert float(same) == pytest.approx(130.0, abs=1e-4)
    _, up = thrust_next(params, state, jnp.float32(100.0), jnp.float32(60.0))
    assert float(up) == pytest.approx(100.0 + 0.2715, abs=1e-4)


def test_second_order_prior_integrates_its_rate(variables: dict) -> None:
    # T[k+1] = T + p dt, p[k+1] = p + Tddot(T, p, u) dt (Euler), the LSTM silent
    params = _silent(variables, P250_COEFFS)
    state = (*params.zero_state()[:2], jnp.float32(40.0))
    state, thrust = thrust_next(params, state, jnp.float32(150.0), jnp.float32(80.0))
    assert float(thrust) == pytest.approx(150.4, abs=1e-4)
    expected = 40.0 + 0.01 * thrust_acceleration(P250_COEFFS, 150.0, 40.0, 80.0)
    assert float(state[2]) == pytest.approx(expected, rel=1e-5)


def test_grey_box_step_is_the_baseline_model() -> None:
    rng = np.random.default_rng(2)
    coeffs = P250_COEFFS * (1 + 0.05 * rng.standard_normal(13))
    t = np.arange(3000) * 0.01
    throttle = np.clip(50 + 40 * np.sin(0.7 * t) + 10 * np.sin(3.1 * t), 0, 100)
    measured = 100 + 40 * np.sin(0.7 * t - 0.5)
    expected = GreyBox(tuple(coeffs)).free_run(measured, throttle, 50, 0.01)
    params = GreyBoxThrust(jnp.asarray(coeffs, jnp.float32), 0.01)
    got = free_run_jit(params, jnp.asarray(measured), jnp.asarray(throttle), 50)
    assert got.shape == expected.shape == (2950,)
    np.testing.assert_allclose(np.asarray(got), expected, atol=2e-3)
    # at rest (Tdot = 0) from the start; jit and vmap over jets
    assert initial_state(params, jnp.float32(80.0), jnp.float32(40.0)) == (0.0,)
    batched = jax.jit(jax.vmap(thrust_next, in_axes=(None, 0, 0, 0)))
    state = (jnp.zeros(3),)
    _, out = batched(params, state, jnp.array([20.0, 100.0, 200.0]), jnp.full(3, 50.0))
    for i, thrust in enumerate([20.0, 100.0, 200.0]):
        _, one = thrust_next(params, (jnp.zeros(()),), jnp.float32(thrust), jnp.float32(50.0))
        assert float(out[i]) == pytest.approx(float(one), rel=1e-6)


def test_dead_time_feeds_the_throttle_late(variables: dict) -> None:
    # with a dead time of 3 steps the model on u equals the model without on u 3 steps late
    params = LSTMThrust.from_variables({**variables, "prior": jnp.asarray(P250_COEFFS)}, NORM, 0.01)
    late = params.replace(delay=3)
    assert [s.shape for s in late.zero_state()] == [(HIDDEN,), (HIDDEN,), (), (3,)]
    rng = np.random.default_rng(4)
    thrust = jnp.asarray(100 + 20 * rng.standard_normal(60), jnp.float32)
    throttle = rng.uniform(0, 100, 60)
    shifted = jnp.asarray(np.concatenate([np.zeros(3), throttle[:-3]]), jnp.float32)
    expected = free_run(params, thrust, shifted, 10)
    got = free_run(late, thrust, jnp.asarray(throttle, jnp.float32), 10)
    np.testing.assert_allclose(np.asarray(got), np.asarray(expected), rtol=1e-6, atol=1e-4)
    # the queue: the oldest throttle drives the step, the newest joins the end
    state = (*late.zero_state()[:3], jnp.array([10.0, 20.0, 30.0]))
    state, _ = thrust_next(late, state, jnp.float32(100.0), jnp.float32(40.0))
    np.testing.assert_array_equal(np.asarray(state[3]), [20.0, 30.0, 40.0])
