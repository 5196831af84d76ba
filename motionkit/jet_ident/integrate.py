"""Fine integration of engine models in JAX: RK4 substeps under a zero-order hold of the
throttle. `simulate` integrates the second-order P250 structure (`motionkit.jet_ident.p250`)
for any coefficient vector; `integrate` any model given as a derivative function."""

from __future__ import annotations

from collections.abc import Callable, Hashable
from functools import partial
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

from motionkit.jet_ident.p250 import SCALES, thrust_acceleration

# derivative(params, static, state, u) -> d state / dt; params traced, static hashable
Derivative = Callable[[Any, Any, jax.Array, jax.Array], jax.Array]


def rk4(slope: Callable[[jax.Array], jax.Array], state: jax.Array, h: Any) -> jax.Array:
    """One classical Runge-Kutta step of `h` for d state / dt = slope(state)."""
    k1 = slope(state)
    k2 = slope(state + 0.5 * h * k1)
    k3 = slope(state + 0.5 * h * k2)
    k4 = slope(state + h * k3)
    return state + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)


@partial(jax.jit, static_argnames=("derivative", "static", "substeps"))
def _integrate(
    derivative: Derivative,
    static: Hashable,
    params: Any,
    throttle: jax.Array,
    dt: jax.Array,
    start: jax.Array,
    substeps: int,
) -> jax.Array:
    h = dt / substeps

    def substep(state: jax.Array, u: jax.Array) -> tuple[jax.Array, None]:
        return rk4(lambda s: derivative(params, static, s, u), state, h), None

    def sample(state: jax.Array, u: jax.Array) -> tuple[jax.Array, jax.Array]:
        state, _ = jax.lax.scan(substep, state, u, length=substeps)
        return state, state

    u_fine = jnp.broadcast_to(throttle[:, None], (throttle.shape[0], substeps))
    _, states = jax.lax.scan(sample, start, u_fine)
    return states


def integrate(
    derivative: Derivative,
    static: Hashable,
    params: Any,
    throttle: np.ndarray,
    dt: float,
    start: np.ndarray,
    substeps: int,
) -> np.ndarray:
    """States after each sample (float32 arithmetic): throttle[k] is held during sample k and
    integrated by `substeps` RK4 steps. Returns an array (len(throttle), len(start))."""
    states = _integrate(
        derivative,
        static,
        jax.tree.map(lambda p: jnp.asarray(p, jnp.float32), params),
        jnp.asarray(throttle, jnp.float32),
        jnp.float32(dt),
        jnp.asarray(start, jnp.float32),
        substeps,
    )
    return np.asarray(states, dtype=np.float64)


def _p250(coeffs: jax.Array, scales: tuple[float, ...], state: jax.Array, u: jax.Array):
    return jnp.stack([state[1], thrust_acceleration(coeffs, state[0], state[1], u, scales)])


def simulate(
    coeffs: np.ndarray,
    throttle: np.ndarray,
    dt: float,
    thrust0: float,
    rate0: float = 0.0,
    substeps: int = 10,
    scales: tuple[float, ...] = SCALES,
) -> np.ndarray:
    """States (T, Tdot) of the P250 structure after each sample (see `integrate`)."""
    start = np.array([thrust0, rate0])
    return integrate(_p250, tuple(scales), coeffs, throttle, dt, start, substeps)
