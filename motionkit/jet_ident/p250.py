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

# The second-order structure published for the P100/P220 (RA-L 2020), in thrust T [N] and
# throttle u [%], Td = dT/dt:
#     Tddot = K_T T + K_TT T^2 + K_D Td + K_DD Td^2 + K_TD T Td
#             + (B_U + B_T T + B_D Td)(u + B_UU u^2) + c
# is this one without normalisation (UNSCALED) and with g linear in T and Td (rate_form_coeffs).
UNSCALED = (0.0, 1.0, 0.0, 1.0)
RATE_FORM = ("K_T", "K_TT", "K_D", "K_DD", "K_TD", "B_U", "B_T", "B_D", "B_UU", "c")
# A P220 (kerosene) in that structure, as iRonCub-Mk1_1's jets.ini publishes it: it idles at
# 15.0 N and gives 220.2 N at full throttle.
P220_RATE_FORM = (
    *(0.237755, -0.012799, -0.860374, 0.023606, 0.008599),
    *(1.139026, 0.019914, -0.050257, 0.000302, -0.692913),
)


def rate_form_coeffs(rate_form: Any) -> np.ndarray:
    """c0..c12 of this structure (with UNSCALED) for the RATE_FORM coefficients."""
    k_t, k_tt, k_d, k_dd, k_td, b_u, b_t, b_d, b_uu, c = (float(k) for k in rate_form)
    return np.array([c, k_t, k_d, k_td, k_tt, k_dd, b_u, b_t, b_d, 0.0, 0.0, 0.0, b_uu])


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
    """Tddot [N/s^2] at thrust [N], thrust rate [N/s] and throttle [%].

    Plain arithmetic: floats, numpy or JAX arrays (broadcast together) or CasADi symbols.

    Args:
        coeffs: c0..c12, shape (13,) (P250_COEFFS: the published P250).
        thrust: the thrust T [N].
        rate: the thrust rate Tdot [N/s].
        throttle: the throttle u [%].
        scales: the normalisation (thrust offset [N], thrust scale [N], throttle offset [%],
            throttle scale [%]); the published P250's by default.

    Returns:
        Tddot [N/s^2], of the broadcast shape of thrust, rate and throttle.
    """
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
