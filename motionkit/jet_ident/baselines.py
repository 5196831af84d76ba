"""Two baselines fitted by least squares on the same logs as the LSTM.

- Grey box: the published second-order structure (p250.py, 13 coefficients) fitted to the
  thrust acceleration (equation error); thrust, rate and acceleration come from a
  Savitzky-Golay filter (cubic, `smoothing_s` wide) of the measured thrust.
- First-order lag: Tdot = (Tss(u) - T) / tau with a quadratic static map Tss(u) = a0 + a1 u +
  a2 u^2, linear in (b0, b1, b2, b3) of Tdot = b0 + b1 u + b2 u^2 + b3 T.

Both free-run like the LSTM: from the measured thrust at sample warmup - 1, at rest.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares
from scipy.signal import savgol_filter

from motionkit.core.errors import JetIdentError
from motionkit.jet_ident.benchlog import BenchLog
from motionkit.jet_ident.integrate import simulate
from motionkit.jet_ident.p250 import THRUST_SCALE, regressors, thrust_acceleration


@dataclass(frozen=True)
class GreyBox:
    coeffs: tuple[float, ...]  # the 13 normalised coefficients c0..c12 (see p250.py)

    def free_run(
        self, thrust: np.ndarray, throttle: np.ndarray, warmup: int, dt: float
    ) -> np.ndarray:
        states = simulate(np.array(self.coeffs), throttle[warmup - 1 : -1], dt, thrust[warmup - 1])
        return np.nan_to_num(states[:, 0], nan=0.0, posinf=1e4, neginf=-1e4)


@dataclass(frozen=True)
class FirstOrderLag:
    tau: float  # time constant [s]
    static: tuple[float, float, float]  # Tss(u) = a0 + a1 u + a2 u^2 [N], u in %

    def steady(self, throttle: np.ndarray) -> np.ndarray:
        a0, a1, a2 = self.static
        return a0 + a1 * throttle + a2 * throttle**2

    def free_run(
        self, thrust: np.ndarray, throttle: np.ndarray, warmup: int, dt: float
    ) -> np.ndarray:
        decay = np.exp(-dt / self.tau)
        target = self.steady(throttle[warmup - 1 : -1])
        out = np.empty(len(target))
        value = thrust[warmup - 1]
        for k, goal in enumerate(target):  # exact for a throttle held over each sample
            value = goal + (value - goal) * decay
            out[k] = value
        return out


def smoothed(thrust: np.ndarray, dt: float, smoothing_s: float) -> tuple[np.ndarray, ...]:
    """Thrust, rate and acceleration by a cubic Savitzky-Golay filter about `smoothing_s` wide."""
    window = max(5, 2 * round(smoothing_s / dt / 2) + 1)
    return tuple(savgol_filter(thrust, window, 3, deriv=d, delta=dt) for d in range(3))


def _samples(logs: Sequence[BenchLog], smoothing_s: float) -> tuple[np.ndarray, ...]:
    if not logs:
        raise JetIdentError("no bench logs given")
    parts = [(*smoothed(log.thrust, log.dt, smoothing_s), log.throttle) for log in logs]
    return tuple(np.concatenate(column) for column in zip(*parts, strict=True))


def fit_grey_box(logs: Sequence[BenchLog], smoothing_s: float = 0.3) -> GreyBox:
    """Least-squares fit of the 13 coefficients to the logs' smoothed thrust acceleration.

    Args:
        logs: the bench logs, pooled.
        smoothing_s: the width of the Savitzky-Golay filter that gives thrust, rate and
            acceleration [s].

    Returns:
        The GreyBox: c0..c12 of the second-order structure with the P250's normalisation.

    Raises:
        JetIdentError: no logs.
    """
    return grey_box_from_samples(*_samples(logs, smoothing_s))


def grey_box_from_samples(
    thrust: np.ndarray, rate: np.ndarray, accel: np.ndarray, throttle: np.ndarray
) -> GreyBox:
    """Least squares of the 13 coefficients on (thrust, rate, acceleration, throttle) samples."""
    terms, v = regressors(thrust, rate, throttle)
    target = accel / THRUST_SCALE
    # c12 = 0 makes the model linear in c0..c11: that solution starts the full fit.
    design = np.stack(terms + [term * v for term in terms], axis=1)
    linear, *_ = np.linalg.lstsq(design, target, rcond=None)

    def residual(coeffs: np.ndarray) -> np.ndarray:
        return thrust_acceleration(coeffs, thrust, rate, throttle) / THRUST_SCALE - target

    result = least_squares(residual, np.append(linear, 0.0), method="lm")
    return GreyBox(tuple(float(c) for c in result.x))


def fit_first_order(logs: Sequence[BenchLog], smoothing_s: float = 0.3) -> FirstOrderLag:
    """Least-squares fit of Tdot = b0 + b1 u + b2 u^2 + b3 T; tau = -1 / b3.

    Args:
        logs: the bench logs, pooled.
        smoothing_s: the width of the Savitzky-Golay filter that gives thrust and rate [s].

    Returns:
        The FirstOrderLag: its time constant tau [s] and static map Tss(u) = a0 + a1 u +
        a2 u^2 [N], u in %.

    Raises:
        JetIdentError: no logs, or an unstable fit (b3 >= 0: no settling thrust in the logs).
    """
    thrust, rate, _, throttle = _samples(logs, smoothing_s)
    return first_order_from_samples(thrust, rate, throttle)


def first_order_from_samples(
    thrust: np.ndarray, rate: np.ndarray, throttle: np.ndarray
) -> FirstOrderLag:
    """Least squares of Tdot = b0 + b1 u + b2 u^2 + b3 T on samples."""
    design = np.stack([np.ones_like(thrust), throttle, throttle**2, thrust], axis=1)
    (b0, b1, b2, b3), *_ = np.linalg.lstsq(design, rate, rcond=None)
    if b3 >= 0:
        raise JetIdentError("the first-order fit is unstable (the logs hold no settling thrust)")
    tau = -1.0 / b3
    return FirstOrderLag(float(tau), (float(b0 * tau), float(b1 * tau), float(b2 * tau)))
