"""The synthetic bench: seeded, and each imperfection doing what its doc says."""

from dataclasses import replace

import numpy as np
import pytest

from motionkit.jet_ident.config import BenchConfig
from motionkit.jet_ident.evaluate import noise_sigma
from motionkit.jet_ident.integrate import simulate
from motionkit.jet_ident.p250 import P250_COEFFS, steady_thrust
from motionkit.jet_ident.synthetic import identification_profile, synthetic_run

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
