"""Fine integration of the second-order P250 structure (`motionkit.jet_ident.p250`) in JAX:
RK4 substeps under a zero-order hold of the throttle, for any coefficient vector."""

from __future__ import annotations

from functools import partial

import jax
import jax.numpy as jnp
import numpy as np

from motionkit.jet_ident.p250 import thrust_acceleration


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
