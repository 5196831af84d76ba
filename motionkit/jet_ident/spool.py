"""A second engine structure for the synthetic bench: the spool (shaft-speed) model of a small
turbojet, built from how such engines work rather than fitted to one.

- The ECU governs shaft speed: the throttle u [%] sets a speed demand linear between idle and
  full speed, n_d = n_idle + (1 - n_idle) u / 100 (n: fraction of full speed).
- Fuel metering and combustion follow the demand with a lag: m' = (n_d - m) / tau_fuel
  (tau_fuel = 0: m = n_d, and the model is first order).
- The rotor follows with a time constant that falls with speed, tau(n) = tau_full / n (the
  excess torque grows with the mass flow through the engine, about in proportion to speed):
  r = (m - n) n / tau_full.
- The ECU limits acceleration (compressor surge, over-temperature) and deceleration (flame-out):
  n' = r / sqrt(1 + (r / a)^2), a = accel_limit[0] when r > 0, else accel_limit[1] [1/s].
- Thrust grows with about the square of speed (mass flow and jet velocity both scale with it);
  T = T_max n^e with an exponent e a little above 2 for small turbojets.

State (n, m); the functions use JAX arithmetic (integrate.py integrates them).
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np

from motionkit.jet_ident.config import SpoolPlant


def speed_demand(plant: SpoolPlant, throttle: jax.Array | np.ndarray) -> jax.Array:
    return plant.idle_speed + (1.0 - plant.idle_speed) * throttle / 100.0


def derivative(_: None, plant: SpoolPlant, state: jax.Array, u: jax.Array) -> jax.Array:
    """d(n, m)/dt at state (n, m) and throttle u [%]."""
    n, m = state[0], state[1]
    demand = speed_demand(plant, u)
    if plant.fuel_lag_s > 0:
        m_rate = (demand - m) / plant.fuel_lag_s
    else:
        m, m_rate = demand, jnp.zeros_like(m)
    r = (m - n) * n / plant.time_constant_s
    limit = jnp.where(r > 0, plant.accel_limit[0], plant.accel_limit[1])
    return jnp.stack([r / jnp.sqrt(1.0 + (r / limit) ** 2), m_rate])


def thrust(plant: SpoolPlant, speed: np.ndarray) -> np.ndarray:
    """T [N] at speed n."""
    return plant.max_thrust_n * np.asarray(speed) ** plant.thrust_exponent


def rest(plant: SpoolPlant, throttle: float) -> np.ndarray:
    """The state (n, m) at rest under `throttle`."""
    demand = float(speed_demand(plant, throttle))
    return np.array([demand, demand])
