"""Jet engine dynamics: the public second-order JetCat P250 model, thrust T [N] and throttle u [%].

Normalised form (13 coefficients, the public P250 model in the project's reference notes):
t = (T - 108.309) / 65.793, td = Tdot / 65.793, v = (u - 47.333) / 31.483,
Tddot / 65.793 = f + g (v + c12 v^2), f = c0 + c1 t + c2 td + c3 t td + c4 t^2 + c5 td^2,
g = c6 + c7 t + c8 td + c9 t td + c10 t^2 + c11 td^2.
Its steady thrust is 16 N at idle and 222 N at full throttle (public P250 figures: 10-16 N
idle, 222-237 N full), with poles near -1.9 and -4.3 rad/s around mid-range.
"""

from __future__ import annotations

import functools
from typing import TypeVar

import numpy as np

P250 = (
    -0.4647, -8.1317, -6.1954, 0.6611, 1.6767, -0.4833,
    8.7800, -1.0110, -0.5864, 0.5191, -0.4238, -1.4571, -0.00783,
)  # fmt: skip
THRUST_OFFSET, THRUST_SCALE = 108.309, 65.793  # N, N (and N/s for Tdot)
THROTTLE_OFFSET, THROTTLE_SCALE = 47.333, 31.483  # %, %

X = TypeVar("X")


def thrust_acceleration(thrust: X, rate: X, throttle: X) -> X:
    """Tddot [N/s^2] of the P250 model; works on floats, numpy arrays and CasADi symbols."""
    c = P250
    t = (thrust - THRUST_OFFSET) / THRUST_SCALE
    td = rate / THRUST_SCALE
    v = (throttle - THROTTLE_OFFSET) / THROTTLE_SCALE
    f = c[0] + c[1] * t + c[2] * td + c[3] * t * td + c[4] * t * t + c[5] * td * td
    g = c[6] + c[7] * t + c[8] * td + c[9] * t * td + c[10] * t * t + c[11] * td * td
    return THRUST_SCALE * (f + g * (v + c[12] * v * v))  # type: ignore[return-value]


def steady_thrust(throttle: float) -> float:
    """The stable equilibrium thrust [N] at a constant throttle [%] (Tdot = 0)."""
    grid = np.linspace(0.0, 300.0, 30001)
    acc = thrust_acceleration(grid, 0.0, throttle)
    crossing = np.nonzero((acc[:-1] > 0) & (acc[1:] <= 0))[0]  # stable: acceleration falls
    return float(grid[crossing[0]])


@functools.cache
def steady_throttle(thrust: float) -> float:
    """The throttle [%] that holds a thrust [N] steady (bisection; clipped to 0-100 %)."""
    low, high = 0.0, 100.0
    if thrust <= steady_thrust(low):
        return low
    if thrust >= steady_thrust(high):
        return high
    for _ in range(50):
        middle = 0.5 * (low + high)
        low, high = (middle, high) if steady_thrust(middle) < thrust else (low, middle)
    return 0.5 * (low + high)
