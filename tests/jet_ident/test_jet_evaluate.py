"""Free-run metrics on hand-made signals; the noise floor; the plot."""

from pathlib import Path

import numpy as np
import pytest

from motionkit.core.errors import JetIdentError
from motionkit.jet_ident.benchlog import BenchLog
from motionkit.jet_ident.evaluate import evaluate, metrics, noise_floor, plot, report_table

DT = 0.01


def _step_log(tau: float, seconds: float = 20.0) -> tuple[np.ndarray, np.ndarray]:
    """Throttle 20 % for 5 s, then 80 %; thrust a first-order response (20 -> 160 N)."""
    t = np.arange(round(seconds / DT)) * DT
    throttle = np.where(t < 5.0, 20.0, 80.0)
    thrust = np.where(t < 5.0, 20.0, 160.0 - 140.0 * np.exp(-(t - 5.0) / tau))
    return throttle, thrust


class Offset:
    def __init__(self, offset: float) -> None:
        self.offset = offset

    def free_run(self, thrust: np.ndarray, throttle: np.ndarray, warmup: int, dt: float):
        return thrust[warmup:] + self.offset


def test_constant_offset() -> None:
    throttle, thrust = _step_log(0.5)
    m = metrics(thrust, thrust[50:] + 2.0, throttle, 50, DT)
    assert (m.mae, m.rmse, m.max) == pytest.approx((2.0, 2.0, 2.0))
    assert m.steady == pytest.approx(2.0) and m.holds == 2  # 20 % and 80 % holds
    assert m.rise == pytest.approx(0.0, abs=1e-9) and m.steps == 1
    assert m.samples == len(thrust) - 50


def test_rise_time_error_of_a_slower_model() -> None:
    throttle, measured = _step_log(0.5)
    _, slower = _step_log(0.7)
    m = metrics(measured, slower[50:], throttle, 50, DT)
    # 63 % of a first-order step at t = -tau ln 0.37 = 0.994 tau: 0.2 x 0.994 s later
    assert m.rise == pytest.approx(0.199, abs=0.012)
    assert m.mae > 0 and m.steady < 0.01  # both settle at 160 N


def test_noise_floor_of_white_noise() -> None:
    rng = np.random.default_rng(0)
    _, thrust = _step_log(0.5, 200.0)
    noisy = thrust + 1.5 * rng.standard_normal(len(thrust))
    t = np.arange(len(thrust)) * DT
    mae, rmse = noise_floor([BenchLog(t, np.zeros_like(t), noisy)])
    assert rmse == pytest.approx(1.5, rel=0.03)
    assert mae == pytest.approx(1.5 * np.sqrt(2 / np.pi), rel=0.03)


def test_evaluate_pools_logs_and_table() -> None:
    throttle, thrust = _step_log(0.5)
    t = np.arange(len(thrust)) * DT
    logs = [BenchLog(t, throttle, thrust), BenchLog(t, throttle, thrust + 5)]
    results, runs = evaluate({"perfect": Offset(0.0), "off": Offset(3.0)}, logs, 20)
    assert results["perfect"].mae == 0.0 and results["off"].rmse == pytest.approx(3.0)
    assert results["off"].samples == 2 * (len(t) - 20) and len(runs["off"]) == 2
    table = report_table(results, (1.0, 1.25))
    assert "perfect" in table and "noise floor" in table and "1.250" in table
    with pytest.raises(JetIdentError, match="evaluation needs"):
        evaluate({"x": Offset(0)}, [BenchLog(t[:30], throttle[:30], thrust[:30])], 20)


def test_plot_writes_png_or_says_matplotlib_is_missing(tmp_path: Path) -> None:
    throttle, thrust = _step_log(0.5)
    t = np.arange(len(thrust)) * DT
    log = BenchLog(t, throttle, thrust, "step")
    try:
        import matplotlib  # noqa: F401
    except ImportError:
        with pytest.raises(JetIdentError, match="needs matplotlib"):
            plot(tmp_path / "p.png", log, {"m": thrust[10:] + 1}, 10)
        assert not (tmp_path / "p.png").exists()
        return
    plot(tmp_path / "p.png", log, {"m": thrust[10:] + 1}, 10)
    assert (tmp_path / "p.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


class _Steady:
    """A stand-in model: 15 N plus 2 N per throttle percent, after the warm-up."""

    def free_run(self, thrust, throttle, warmup, dt):
        return 15.0 + 2.0 * np.asarray(throttle)[warmup:]


def test_a_log_on_another_thrust_scale_is_refused() -> None:
    """A log in kN (or of another engine) against the model's free run: one clear error, not
    an MAE that looks like a result; within 3x of the model's thrust the log is evaluated."""
    time = np.arange(400) * 0.01
    throttle = np.where(time < 2.0, 20.0, 60.0)
    newtons = 15.0 + 2.0 * throttle + 0.5
    log = BenchLog(time, throttle, newtons, name="bench.csv")
    results, _ = evaluate({"LSTM": _Steady()}, [log], 50)
    assert results["LSTM"].mae == pytest.approx(0.5, abs=1e-9)
    kilonewtons = BenchLog(time, throttle, newtons / 1000, name="bench_kn.csv")
    with pytest.raises(JetIdentError, match=r"bench_kn.csv: thrust_n averages 0\.1\d* N where"):
        evaluate({"LSTM": _Steady()}, [kilonewtons], 50)
