"""The published P250 model: derivative values by hand, equilibria, rise time, integration."""

import numpy as np
import pytest

from motionkit.jet_ident.integrate import simulate
from motionkit.jet_ident.p250 import (
    P250_COEFFS,
    SCALES,
    retimed,
    steady_throttle,
    steady_thrust,
    thrust_acceleration,
)

# Tddot at (T, Tdot, u) from the two copies of the model before they became one (trajopt's
# and jet_ident's thrust_acceleration, float64; both gave these values bit for bit).
ACCELERATIONS = {
    (16.0, 0.0, 0.0): 0.029778344871722394,
    (150.0, -40.0, 80.0): 407.7543500179175,
    (222.0, 12.5, 100.0): -62.80994642746992,
    (60.0, 25.0, 30.0): -66.94542908004034,
}
# Steady thrust at u = 0, 25, 50, 75, 100 % by the former bisection of jet_ident (60 halvings
# of 0-400 N); trajopt's former grid search gave the same roots floored to 0.01 N.
STEADY = (16.002271841175222, 58.60685511208321, 110.55481295885554, 168.94988305562322)
STEADY += (222.12510140059817,)


def test_acceleration_at_the_normalisation_centre_is_65_793_c0() -> None:
    # t = td = v = 0: Tddot = 65.793 * c0 = 65.793 * -0.4647
    value = thrust_acceleration(P250_COEFFS, 108.309, 0.0, 47.333)
    assert value == pytest.approx(-30.5740071, abs=1e-6)


def test_acceleration_at_unit_normalised_point() -> None:
    # t = td = v = 1: f = c0 + ... + c5 = -12.9373, g = c6 + ... + c11 = 5.8208,
    # v + c12 v^2 = 0.99217; Tddot = 65.793 * (-12.9373 + 5.8208 * 0.99217) = -471.2143...
    thrust, rate, throttle = 108.309 + 65.793, 65.793, 47.333 + 31.483
    expected = 65.793 * (-12.9373 + 5.8208 * 0.99217)
    assert thrust_acceleration(P250_COEFFS, thrust, rate, throttle) == pytest.approx(expected)
    assert expected == pytest.approx(-471.2143, abs=1e-3)


def test_acceleration_mixed_point_term_by_term() -> None:
    # t = -1, td = 0.5, v = -1 (T = 42.516 N, Tdot = 32.8965 N/s, u = 15.85 %)
    t, td, v = -1.0, 0.5, -1.0
    c = P250_COEFFS
    f = c[0] + c[1] * t + c[2] * td + c[3] * t * td + c[4] * t * t + c[5] * td * td
    g = c[6] + c[7] * t + c[8] * td + c[9] * t * td + c[10] * t * t + c[11] * td * td
    assert f == pytest.approx(-0.4647 + 8.1317 - 3.0977 - 0.33055 + 1.6767 - 0.120825)
    assert g == pytest.approx(8.78 + 1.011 - 0.2932 - 0.25955 - 0.4238 - 0.364275)
    expected = 65.793 * (f + g * (v + c[12] * v * v))
    value = thrust_acceleration(P250_COEFFS, 42.516, 32.8965, 15.85)
    assert value == pytest.approx(expected, rel=1e-9)


def test_acceleration_is_unchanged_by_the_merge() -> None:
    for (thrust, rate, throttle), value in ACCELERATIONS.items():
        assert thrust_acceleration(P250_COEFFS, thrust, rate, throttle) == pytest.approx(
            value, rel=1e-12, abs=1e-12
        )


def test_steady_thrust_is_the_former_root_and_stable() -> None:
    throttle = np.array([0.0, 25.0, 50.0, 75.0, 100.0])
    thrust = steady_thrust(P250_COEFFS, throttle)
    np.testing.assert_allclose(thrust, STEADY, rtol=0, atol=1e-12)
    assert np.all(np.abs(thrust_acceleration(P250_COEFFS, thrust, 0.0, throttle)) < 1e-9)
    # stable: a little more thrust decelerates, a little less accelerates
    assert np.all(thrust_acceleration(P250_COEFFS, thrust + 1.0, 0.0, throttle) < 0)
    assert np.all(thrust_acceleration(P250_COEFFS, thrust - 1.0, 0.0, throttle) > 0)
    # the unstable root at idle lies near 387.5 N, inside the former 0-400 N search
    above = thrust_acceleration(P250_COEFFS, np.array([387.0, 388.0]), 0.0, 0.0)
    assert above[0] < 0 < above[1]


def test_steady_throttle_inverts_steady_thrust_and_clips() -> None:
    throttle = np.array([0.0, 10.0, 47.333, 90.0, 100.0])
    thrust = steady_thrust(P250_COEFFS, throttle)
    np.testing.assert_allclose(steady_throttle(P250_COEFFS, thrust), throttle, atol=1e-9)
    # below idle: 0 %; above full thrust: 100 % (also where g < 0, beyond 339 N)
    np.testing.assert_allclose(steady_throttle(P250_COEFFS, [5.0, 240.0, 350.0]), [0, 100, 100])


def test_equilibria_match_the_published_figures() -> None:
    idle, full = steady_thrust(P250_COEFFS, np.array([0.0, 100.0]))
    assert 10 <= idle <= 16.5 and idle == pytest.approx(16.0, abs=0.1)
    assert 222 <= full <= 237
    assert abs(thrust_acceleration(P250_COEFFS, full, 0.0, 100.0)) < 1e-6


def test_idle_to_full_rise_time_is_about_1_4_s() -> None:
    idle, full = steady_thrust(P250_COEFFS, np.array([0.0, 100.0]))
    states = simulate(P250_COEFFS, np.full(800, 100.0), 0.01, idle)
    reached = np.argmax(states[:, 0] >= idle + 0.632 * (full - idle))
    assert 1.3 <= (reached + 1) * 0.01 <= 1.5
    assert states[-1, 0] == pytest.approx(full, abs=0.5)


def test_rk4_substeps_agree_with_a_much_finer_integration() -> None:
    throttle = np.repeat([20.0, 80.0, 40.0], 150)
    coarse = simulate(P250_COEFFS, throttle, 0.01, 40.0, substeps=2)
    fine = simulate(P250_COEFFS, throttle, 0.01, 40.0, substeps=40)
    assert np.max(np.abs(coarse[:, 0] - fine[:, 0])) < 0.02


def test_another_normalisation_is_another_engine() -> None:
    # Offsets and scales twice the published: the same engine at twice the thrust.
    double = (2 * SCALES[0], 2 * SCALES[1], SCALES[2], SCALES[3])
    throttle = np.array([0.0, 50.0, 100.0])
    np.testing.assert_allclose(
        steady_thrust(P250_COEFFS, throttle, double), 2 * steady_thrust(P250_COEFFS, throttle)
    )
    value = thrust_acceleration(P250_COEFFS, 2 * 150.0, 2 * -40.0, 80.0, double)
    assert value == pytest.approx(2 * ACCELERATIONS[(150.0, -40.0, 80.0)], rel=1e-12)
    np.testing.assert_allclose(
        steady_throttle(P250_COEFFS, [120.0, 300.0], double),
        steady_throttle(P250_COEFFS, [60.0, 150.0]),
        atol=1e-9,
    )


def test_retimed_coefficients_run_the_engine_slower() -> None:
    # speed 0.5: sample k at 0.02 s of the slow engine is sample k at 0.01 s of the published
    slow = retimed(P250_COEFFS, 0.5)
    assert slow[0] == pytest.approx(0.25 * P250_COEFFS[0]) and slow[12] == P250_COEFFS[12]
    assert slow[2] == pytest.approx(0.5 * P250_COEFFS[2]) and slow[5] == P250_COEFFS[5]
    throttle = np.repeat([20.0, 90.0, 40.0], 200)
    fast = simulate(P250_COEFFS, throttle, 0.01, 50.0)
    np.testing.assert_allclose(simulate(slow, throttle, 0.02, 50.0)[:, 0], fast[:, 0], atol=2e-3)
