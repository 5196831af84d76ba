"""The LSTM thrust model T[k+1] = T[k] + g(T[k], u[k]) dt, with g an LSTM (flax.linen).

Inputs are normalised by the training data's means and standard deviations; the LSTM's output
is the thrust rate in units of `rate_scale` [N/s]. This module holds the training-time form
(flax variables); step.py holds the exported form the simulator runs.
"""

from __future__ import annotations

from typing import Any

import flax.linen as nn
import jax
import jax.numpy as jnp
import numpy as np
from flax import struct

Carry = tuple[jax.Array, jax.Array]  # LSTM (c, h)


@struct.dataclass
class Normalisation:
    thrust_mean: float  # N
    thrust_std: float  # N
    throttle_mean: float  # %
    throttle_std: float  # %
    rate_scale: float  # N/s per unit of the LSTM's output

    @classmethod
    def fit(cls, thrust: np.ndarray, throttle: np.ndarray) -> Normalisation:
        """From training samples; the rate scale is one thrust standard deviation per second."""
        std = float(np.std(thrust))
        return cls(
            float(np.mean(thrust)), std, float(np.mean(throttle)), float(np.std(throttle)), std
        )

    def inputs(self, thrust: jax.Array, throttle: jax.Array) -> jax.Array:
        return jnp.stack(
            [
                (thrust - self.thrust_mean) / self.thrust_std,
                (throttle - self.throttle_mean) / self.throttle_std,
            ],
            axis=-1,
        )


class ThrustLSTM(nn.Module):
    """One step: (carry, normalised inputs [..., 2]) -> (carry, normalised thrust rate [...])."""

    hidden: int

    @nn.compact
    def __call__(self, carry: Carry, inputs: jax.Array) -> tuple[Carry, jax.Array]:
        carry, h = nn.LSTMCell(self.hidden, name="cell")(carry, inputs)
        return carry, nn.Dense(1, name="head")(h)[..., 0]


def zero_carry(hidden: int, batch: tuple[int, ...] = ()) -> Carry:
    return jnp.zeros((*batch, hidden)), jnp.zeros((*batch, hidden))


def init_variables(hidden: int, seed: int) -> dict[str, Any]:
    """Fresh flax variables; the head starts near zero (the thrust holds still at first)."""
    module = ThrustLSTM(hidden)
    variables = module.init(jax.random.key(seed), zero_carry(hidden), jnp.zeros(2))
    head = variables["params"]["head"]
    head = {"kernel": head["kernel"] * 0.1, "bias": jnp.zeros_like(head["bias"])}
    return {"params": {**variables["params"], "head": head}}


def lstm_step(
    hidden: int,
    variables: dict[str, Any],
    norm: Normalisation,
    dt: float,
    carry: Carry,
    thrust: jax.Array,
    throttle: jax.Array,
) -> tuple[Carry, jax.Array]:
    """The training-time step: next carry and next thrust [N]."""
    carry, rate = ThrustLSTM(hidden).apply(variables, carry, norm.inputs(thrust, throttle))
    return carry, thrust + rate * norm.rate_scale * dt


def rollout(
    hidden: int,
    variables: dict[str, Any],
    norm: Normalisation,
    dt: float,
    thrust: jax.Array,
    throttle: jax.Array,
    warmup: int,
) -> jax.Array:
    """Free-run thrust for samples warmup..n-1 of one window (time on the last axis).

    The first `warmup` samples feed the measured thrust (they set the LSTM state); from sample
    `warmup - 1` on, the model feeds itself. Works on a batch of windows (leading axes)."""
    hidden_carry = zero_carry(hidden, thrust.shape[:-1])
    step = lambda carry, t, u: lstm_step(hidden, variables, norm, dt, carry, t, u)  # noqa: E731

    def forced(carry: Carry, sample: tuple[jax.Array, jax.Array]) -> tuple[Carry, None]:
        carry, _ = step(carry, *sample)
        return carry, None

    def free(state: tuple[Carry, jax.Array], u: jax.Array) -> tuple[Any, jax.Array]:
        carry, t = step(*state, u)
        return (carry, t), t

    thrust_t, throttle_t = jnp.moveaxis(thrust, -1, 0), jnp.moveaxis(throttle, -1, 0)
    carry, _ = jax.lax.scan(
        forced, hidden_carry, (thrust_t[: warmup - 1], throttle_t[: warmup - 1])
    )
    _, simulated = jax.lax.scan(free, (carry, thrust_t[warmup - 1]), throttle_t[warmup - 1 : -1])
    return jnp.moveaxis(simulated, 0, -1)
