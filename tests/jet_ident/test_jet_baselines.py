"""Baselines recover the parameters of data they generate."""

from dataclasses import replace

import numpy as np
import pytest

from motionkit.jet_ident.baselines import (
    FirstOrderLag,
    GreyBox,
    first_order_from_samples,
    fit_first_order,
    fit_grey_box,
    grey_box_from_samples,
)
from motionkit.jet_ident.benchlog import BenchLog
from motionkit.jet_ident.config import BenchConfig
from motionkit.jet_ident.p250 import P250_COEFFS, thrust_acceleration
from motionkit.jet_ident.synthetic import synthetic_run


def test_grey_box_least_squares_is_exact_on_exact_samples() -> None:
    rng = np.random.default_rng(0)
    thrust, rate = rng.uniform(10, 230, 400), rng.uniform(-200, 200, 400)
    throttle = rng.uniform(0, 100, 400)
    accel = thrust_acceleration(P250_COEFFS, thrust, rate, throttle)
    fitted = grey_box_from_samples(thrust, rate, accel, throttle)
    np.testing.assert_allclose(fitted.coeffs, P250_COEFFS, atol=1e-6)


def test_first_order_least_squares_is_exact_on_exact_samples() -> None:
    rng = np.random.default_rng(1)
    lag = FirstOrderLag(0.6, (12.0, 1.6, 0.006))
    thrust, throttle = rng.uniform(10, 230, 300), rng.uniform(0, 100, 300)
    rate = (lag.steady(throttle) - thrust) / lag.tau
    fitted = first_order_from_samples(thrust, rate, throttle)
    assert fitted.tau == pytest.approx(0.6)
    np.testing.assert_allclose(fitted.static, lag.static, rtol=1e-8)


def test_first_order_from_a_log_it_generated() -> None:
    lag = FirstOrderLag(0.6, (12.0, 1.6, 0.006))
    t = np.arange(12000) * 0.01
    throttle = np.clip(50 + 35 * np.sin(2 * np.pi * 0.03 * t) + 10 * np.sin(1.7 * t), 0, 100)
    padded = np.concatenate([[throttle[0]], throttle])
    thrust = lag.free_run(np.full(len(padded), lag.steady(throttle[0])), padded, 1, 0.01)
    fitted = fit_first_order([BenchLog(t, throttle, thrust)], smoothing_s=0.1)
    assert fitted.tau == pytest.approx(0.6, rel=0.03)
    np.testing.assert_allclose(fitted.steady(np.array([10.0, 50.0, 90.0])), lag.steady(
        np.array([10.0, 50.0, 90.0])), rtol=0.01)  # fmt: skip


def test_grey_box_from_a_clean_p250_log_reproduces_it() -> None:
    ideal = BenchConfig().ideal()
    t = np.arange(15000) * 0.01
    throttle = 50 + 30 * np.sin(2 * np.pi * 0.03 * t) + 12 * np.sin(2 * np.pi * 0.23 * t + 1)
    log = synthetic_run(replace(ideal, duration_s=150.0), 0, np.clip(throttle, 0, 100)).log
    fitted = fit_grey_box([log], smoothing_s=0.1)
    # The coefficients come back within 4 % of the largest (c6 = 8.78); the weakly
    # determined direction (c1, c2, c6 nearly collinear on slow data) takes most of it.
    assert np.max(np.abs(np.array(fitted.coeffs) - P250_COEFFS)) < 0.35
    assert np.sign(fitted.coeffs[1]) == -1 and np.sign(fitted.coeffs[6]) == 1
    simulated = fitted.free_run(log.thrust, log.throttle, 10, 0.01)
    assert np.max(np.abs(simulated - log.thrust[10:])) < 1.0
    published = GreyBox(tuple(P250_COEFFS)).free_run(log.thrust, log.throttle, 10, 0.01)
    assert np.max(np.abs(published - log.thrust[10:])) < 0.2  # it starts at rest, the log not
