"""The synthetic bench: seeded, the default plant pinned, the spool plant, and each
imperfection doing what its doc says."""

import hashlib
from dataclasses import replace

import numpy as np
import pytest

from motionkit.jet_ident import spool
from motionkit.jet_ident.config import BenchConfig, P250Plant, SpoolPlant
from motionkit.jet_ident.evaluate import noise_sigma
from motionkit.jet_ident.family import ENGINES
from motionkit.jet_ident.integrate import simulate
from motionkit.jet_ident.p250 import P250_COEFFS, steady_thrust
from motionkit.jet_ident.synthetic import engine_thrust, identification_profile, synthetic_run

SHORT = BenchConfig(duration_s=120.0)
IDEAL = SHORT.ideal()


def test_profile_is_seeded_and_covers_the_range() -> None:
    a = identification_profile(540, 100, np.random.default_rng(4))
    b = identification_profile(540, 100, np.random.default_rng(4))
    c = identification_profile(540, 100, np.random.default_rng(5))
    np.testing.assert_array_equal(a, b)
    assert not np.array_equal(a, c)
    assert len(a) == 54000 and a.min() >= 0 and a.max() <= 100
    assert np.all(a[:500] == 0) and np.all(a[-500:] == 0)  # starts and ends at idle
    busy = a[500:-1000]
    assert busy.min() < 15 and busy.max() > 85  # moves around 10-90 %


def test_runs_are_seeded() -> None:
    a, b = synthetic_run(SHORT, 3), synthetic_run(SHORT, 3)
    np.testing.assert_array_equal(a.log.thrust, b.log.thrust)
    assert a.log.metadata["seed"] == "3" and a.log.dt == pytest.approx(0.01)


def test_without_imperfections_the_log_is_the_published_model() -> None:
    run = synthetic_run(IDEAL, 2)
    u = run.log.throttle
    start = float(steady_thrust(P250_COEFFS, u[0]))
    states = simulate(P250_COEFFS, u, 0.01, start)
    expected = np.concatenate([[start], states[:-1, 0]])
    np.testing.assert_allclose(run.log.thrust, expected, atol=0.05)


def test_noise_level_and_clean_signal() -> None:
    run = synthetic_run(SHORT, 1)
    noise = run.log.thrust - run.clean
    assert np.std(noise) == pytest.approx(1.5, rel=0.05)
    assert noise_sigma(run.log.thrust) == pytest.approx(1.5, rel=0.05)


def test_delay_shifts_the_response_by_whole_samples() -> None:
    base = synthetic_run(IDEAL, 6)
    late = synthetic_run(replace(IDEAL, delay_s=0.03), 6)
    np.testing.assert_allclose(late.log.thrust[3:], base.log.thrust[:-3], atol=0.05)


def test_ambient_gain_is_the_density_ratio() -> None:
    hot = synthetic_run(replace(IDEAL, ambient_c=(35.0, 35.0)), 6)
    base = synthetic_run(IDEAL, 6)
    ratio = (273.15 + 15) / (273.15 + 35)
    np.testing.assert_allclose(hot.log.thrust, ratio * base.log.thrust, rtol=1e-3, atol=0.02)


def test_sensor_low_pass_lags_a_step() -> None:
    throttle = np.concatenate([np.zeros(300), np.full(300, 100.0)])
    fast = synthetic_run(IDEAL, 0, throttle).log.thrust
    slow = synthetic_run(replace(IDEAL, sensor_cutoff_hz=1.0), 0, throttle).log.thrust
    assert fast[0] == pytest.approx(slow[0], abs=1e-3)  # starts at rest on both
    assert np.all(slow[301:450] < fast[301:450])


def test_quantisation_rounds_the_engine_command() -> None:
    throttle = np.full(400, 50.2)
    coarse = synthetic_run(replace(IDEAL, throttle_step_pct=1.0), 0, throttle)
    exact = float(steady_thrust(P250_COEFFS, 50.0))
    assert coarse.log.thrust[-1] == pytest.approx(exact, abs=1e-2)
    np.testing.assert_allclose(coarse.log.throttle, 50.2)  # the log keeps the command


def test_the_default_plant_is_unchanged() -> None:
    # A 60 s log of seed 7 as the bench made it before engines became configurable.
    run = synthetic_run(BenchConfig(duration_s=60.0), 7)
    thrust = run.log.thrust
    np.testing.assert_array_equal(
        thrust[[0, 1000, 2345, 4000, 5999]], [16.371, 109.866, 186.978, 137.318, 16.75]
    )
    digest = hashlib.sha256(thrust.tobytes()).hexdigest()
    assert digest == "ac68ddd769a6de1c63e18ec9393a317da50f6f08e03d206c48b0545fdef22429"
    # the published plant spelled out is the default
    spelled = replace(BenchConfig(duration_s=60.0), p250=P250Plant(tuple(P250_COEFFS)))
    np.testing.assert_array_equal(synthetic_run(spelled, 7).log.thrust, thrust)


def test_spool_derivative_by_hand() -> None:
    plant = SpoolPlant(200.0, 0.3, 2.5, 0.25, (0.5, 1.0), 0.1)
    # n = 0.5, m = 0.8 at 100 %: demand 1; m' = (1 - 0.8) / 0.1 = 2; r = 0.3 * 0.5 / 0.25 = 0.6
    # above the 0.5 /s limit: n' = 0.6 / sqrt(1 + 1.2^2) = 0.384111
    rate = spool.derivative(None, plant, np.array([0.5, 0.8]), 100.0)
    np.testing.assert_allclose(rate, [0.6 / np.sqrt(2.44), 2.0], rtol=1e-6)
    # slowing down: m = 0.4 at n = 0.5, r = -0.2, limit 1 /s: n' = -0.2 / sqrt(1.04)
    rate = spool.derivative(None, plant, np.array([0.5, 0.4]), 100.0)
    assert float(rate[0]) == pytest.approx(-0.2 / np.sqrt(1.04), rel=1e-6)
    # first order: the demand drives the rotor directly (u = 50 %: n_d = 0.65)
    first = replace(plant, fuel_lag_s=0.0)
    rate = spool.derivative(None, first, np.array([0.5, 0.0]), 50.0)
    np.testing.assert_allclose(rate, [0.3 / np.sqrt(1.36), 0.0], rtol=1e-6)


def test_spool_engine_settles_at_its_static_map() -> None:
    bench = replace(IDEAL, plant="spool")
    plant = bench.spool
    throttle = np.repeat([0.0, 100.0, 50.0], 10000)  # 10 s each at 1 kHz
    thrust = engine_thrust(bench, throttle, 0.001)
    # T = 230 n^2.5 with n = 0.3 + 0.7 u / 100: 11.33 N idle, 230 N full, 78.345 N at 50 %
    assert thrust[9999] == pytest.approx(230 * 0.3**2.5, rel=1e-5)
    assert thrust[19999] == pytest.approx(230.0, rel=1e-4)
    assert thrust[-1] == pytest.approx(230 * 0.65**2.5, rel=1e-4)
    assert spool.thrust(plant, spool.rest(plant, 50.0)[0]) == pytest.approx(78.345, abs=1e-3)
    # the acceleration limit: from idle the speed rises at most 0.5 /s
    speed = (thrust[10000:12000] / 230.0) ** (1 / 2.5)
    assert np.max(np.diff(speed)) / 0.001 <= 0.5 + 1e-3


def test_engines_of_the_family_span_the_published_range() -> None:
    for name, bench in ENGINES.items():
        throttle = np.repeat([0.0, 100.0], 1500)
        thrust = engine_thrust(bench, throttle, 0.01)
        assert 3 < thrust[1499] < 25 and 150 < thrust[-1] < 320, name
