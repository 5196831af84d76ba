"""The published second-order JetCat P250 model and its fine integration.

In normalised variables t = (T - 108.309) / 65.793, td = Tdot / 65.793 and
v = (u - 47.333) / 31.483 (thrust T [N], throttle u [%]):

    Tddot / 65.793 = f + g (v + c12 v^2)
    f = c0 + c1 t + c2 td + c3 t td + c4 t^2 + c5 td^2
    g = c6 + c7 t + c8 td + c9 t td + c10 t^2 + c11 td^2

With the public coefficients the engine idles at 16.0 N (u = 0) and gives 222.1 N at full
throttle; the 63 % rise time from idle to full is 1.39 s. The same functions integrate any
coefficient vector (the grey-box baseline fits one).
"""

from __future__ import annotations

from functools import partial
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

# c0..c12 as published (c0-c5: f, c6-c11: g, c12: the throttle's square).
P250_COEFFS = np.array(
    [
        *(-0.4647, -8.1317, -6.1954, 0.6611, 1.6767, -0.4833),
        *(8.7800, -1.0110, -0.5864, 0.5191, -0.4238, -1.4571),
        -0.00783,
    ]
)
THRUST_OFFSET, THRUST_SCALE = 108.309, 65.793  # N
THROTTLE_OFFSET, THROTTLE_SCALE = 47.333, 31.483  # %


def regressors(thrust: Any, rate: Any, throttle: Any) -> tuple[list[Any], Any]:
    """The six polynomial terms shared by f and g, and v: arrays of any shape (numpy or jax)."""
    t = (thrust - THRUST_OFFSET) / THRUST_SCALE
    td = rate / THRUST_SCALE
    v = (throttle - THROTTLE_OFFSET) / THROTTLE_SCALE
    terms = [t * 0 + 1, t, td, t * td, t * t, td * td]
    return terms, v


def thrust_acceleration(coeffs: Any, thrust: Any, rate: Any, throttle: Any) -> Any:
    """Tddot [N/s^2] at thrust [N], thrust rate [N/s] and throttle [%]."""
    terms, v = regressors(thrust, rate, throttle)
    f = sum(coeffs[i] * terms[i] for i in range(6))
    g = sum(coeffs[6 + i] * terms[i] for i in range(6))
    return THRUST_SCALE * (f + g * (v + coeffs[12] * v * v))


@partial(jax.jit, static_argnames="substeps")
def _integrate(
    coeffs: jax.Array, throttle: jax.Array, dt: jax.Array, start: jax.Array, substeps: int
) -> jax.Array:
    h = dt / substeps

    def derivative(state: jax.Array, u: jax.Array) -> jax.Array:
        return jnp.stack([state[1], thrust_acceleration(coeffs, state[0], state[1], u)])

    def rk4(state: jax.Array, u: jax.Array) -> tuple[jax.Array, None]:
        k1 = derivative(state, u)
        k2 = derivative(state + 0.5 * h * k1, u)
        k3 = derivative(state + 0.5 * h * k2, u)
        k4 = derivative(state + h * k3, u)
        return state + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4), None

    def sample(state: jax.Array, u: jax.Array) -> tuple[jax.Array, jax.Array]:
        state, _ = jax.lax.scan(rk4, state, u, length=substeps)
        return state, state

    u_fine = jnp.broadcast_to(throttle[:, None], (throttle.shape[0], substeps))
    _, states = jax.lax.scan(sample, start, u_fine)
    return states


def simulate(
    coeffs: np.ndarray,
    throttle: np.ndarray,
    dt: float,
    thrust0: float,
    rate0: float = 0.0,
    substeps: int = 10,
) -> np.ndarray:
    """States (T, Tdot) after each sample: throttle[k] is held during sample k (zero-order hold)
    and integrated by `substeps` RK4 steps. Returns an array (len(throttle), 2)."""
    states = _integrate(
        jnp.asarray(coeffs, jnp.float32),
        jnp.asarray(throttle, jnp.float32),
        jnp.float32(dt),
        jnp.array([thrust0, rate0], jnp.float32),
        substeps,
    )
    return np.asarray(states, dtype=np.float64)


def steady_thrust(coeffs: np.ndarray, throttle: np.ndarray | float) -> np.ndarray:
    """The equilibrium thrust [N] at each throttle [%]: the root of Tddot(T, 0, u) in 0-400 N
    where the acceleration turns from positive to negative (bisection)."""
    u = np.asarray(throttle, dtype=float)
    low, high = np.zeros_like(u), np.full_like(u, 400.0)
    for _ in range(60):
        middle = 0.5 * (low + high)
        positive = thrust_acceleration(coeffs, middle, 0.0, u) > 0
        low, high = np.where(positive, middle, low), np.where(positive, high, middle)
    return 0.5 * (low + high)
