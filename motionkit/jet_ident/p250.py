"""The published second-order JetCat P250 model: thrust T [N], throttle u [%].

In normalised variables t = (T - 108.309) / 65.793, td = Tdot / 65.793 and
v = (u - 47.333) / 31.483:

    Tddot / 65.793 = f + g (v + c12 v^2)
    f = c0 + c1 t + c2 td + c3 t td + c4 t^2 + c5 td^2
    g = c6 + c7 t + c8 td + c9 t td + c10 t^2 + c11 td^2

With the public coefficients the engine idles at 16.0 N (u = 0) and gives 222.1 N at full
throttle (public figures: 10-16 N idle, 222-237 N full); the 63 % rise time from idle to full
is 1.39 s. The functions take any coefficient vector (the grey-box baseline fits one) and, as
`scales`, any normalisation (another engine of this structure; the published one by default),
and use plain arithmetic only, so that they work on floats, numpy and JAX arrays and CasADi symbols
(trajopt's dynamics). At rest (Tdot = 0) the model is quadratic in t and in v, so its steady
states are closed-form roots; `motionkit.jet_ident.integrate` integrates it in JAX.
"""

from __future__ import annotations

from typing import Any

import numpy as np

# c0..c12 as published (c0-c5: f, c6-c11: g, c12: the throttle's square).
P250_COEFFS = np.array(
    [
        *(-0.4647, -8.1317, -6.1954, 0.6611, 1.6767, -0.4833),
        *(8.7800, -1.0110, -0.5864, 0.5191, -0.4238, -1.4571),
        -0.00783,
    ]
)
THRUST_OFFSET, THRUST_SCALE = 108.309, 65.793  # N (and N/s for Tdot)
THROTTLE_OFFSET, THROTTLE_SCALE = 47.333, 31.483  # %
# The normalisation (thrust offset, thrust scale, throttle offset, throttle scale): another
# engine of this structure may come with its own, as the keyword `scales` of every function.
SCALES = (THRUST_OFFSET, THRUST_SCALE, THROTTLE_OFFSET, THROTTLE_SCALE)
TD_POWER = (0, 0, 1, 1, 0, 2)  # the power of td in each of the six terms


def regressors(
    thrust: Any, rate: Any, throttle: Any, scales: tuple[float, ...] = SCALES
) -> tuple[list[Any], Any]:
    """The six polynomial terms shared by f and g, and v."""
    thrust_offset, thrust_scale, throttle_offset, throttle_scale = scales
    t = (thrust - thrust_offset) / thrust_scale
    td = rate / thrust_scale
    v = (throttle - throttle_offset) / throttle_scale
    terms = [t * 0 + 1, t, td, t * td, t * t, td * td]
    return terms, v


def _f_g(
    coeffs: Any, thrust: Any, rate: Any, throttle: Any, scales: tuple[float, ...]
) -> tuple[Any, Any, Any]:
    terms, v = regressors(thrust, rate, throttle, scales)
    f = sum(coeffs[i] * terms[i] for i in range(6))
    g = sum(coeffs[6 + i] * terms[i] for i in range(6))
    return f, g, v


def thrust_acceleration(
    coeffs: Any, thrust: Any, rate: Any, throttle: Any, scales: tuple[float, ...] = SCALES
) -> Any:
    """Tddot [N/s^2] at thrust [N], thrust rate [N/s] and throttle [%]."""
    f, g, v = _f_g(coeffs, thrust, rate, throttle, scales)
    return scales[1] * (f + g * (v + coeffs[12] * v * v))


def steady_thrust(
    coeffs: np.ndarray, throttle: np.ndarray | float, scales: tuple[float, ...] = SCALES
) -> np.ndarray:
    """The stable equilibrium thrust [N] at each throttle [%] (NaN where there is none).

    At rest Tddot / 65.793 = a t^2 + b t + c with w = v + c12 v^2, a = c4 + c10 w,
    b = c1 + c7 w, c = c0 + c6 w; the stable root is the one where Tddot falls with t,
    t = (-b - sqrt(b^2 - 4ac)) / 2a, written as 2c / (sqrt(b^2 - 4ac) - b) so that a -> 0
    (a linear model) is no special case.
    """
    thrust_offset, thrust_scale, throttle_offset, throttle_scale = scales
    v = (np.asarray(throttle, dtype=float) - throttle_offset) / throttle_scale
    w = v + coeffs[12] * v * v
    a, b, c = coeffs[4] + coeffs[10] * w, coeffs[1] + coeffs[7] * w, coeffs[0] + coeffs[6] * w
    with np.errstate(invalid="ignore", divide="ignore"):
        t = 2 * c / (np.sqrt(b * b - 4 * a * c) - b)
    return thrust_offset + thrust_scale * t


def steady_throttle(
    coeffs: np.ndarray, thrust: np.ndarray | float, scales: tuple[float, ...] = SCALES
) -> np.ndarray:
    """The throttle [%] that holds each thrust [N] steady: 0 % at or below idle, 100 % at or
    above full thrust. At rest f + g w = 0 gives w = -f / g, and v + c12 v^2 = w its root
    nearest w, v = 2w / (1 + sqrt(1 + 4 c12 w))."""
    idle, full = steady_thrust(coeffs, np.array([0.0, 100.0]), scales)
    f, g, _ = _f_g(coeffs, np.clip(thrust, idle, full), 0.0, scales[2], scales)
    w = -f / g
    v = 2 * w / (1 + np.sqrt(1 + 4 * coeffs[12] * w))
    return np.clip(scales[2] + scales[3] * v, 0.0, 100.0)


def retimed(coeffs: np.ndarray, speed: float) -> np.ndarray:
    """The coefficients of the same engine running `speed` times faster (T(t) -> T(speed t)):
    Tddot scales by speed^2 and td by speed, so each term's coefficient by speed^(2 - power of
    td in it); c12 (the throttle's shape) stays."""
    powers = np.array([*TD_POWER, *TD_POWER])
    return np.append(np.asarray(coeffs[:12]) * speed ** (2.0 - powers), coeffs[12])
