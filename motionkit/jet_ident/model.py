"""The LSTM thrust model T[k+1] = T[k] + g dt, with g an LSTM (flax.linen) on a physical prior.

Inputs are normalised by the training data's means and standard deviations, x = (t, v); the
LSTM's output is the thrust rate in units of `rate_scale` [N/s]. The prior (the variables'
"prior", fitted alone first, then trained with the LSTM) is told by its length:

- none: g = LSTM.
- 6, a first-order engine: g = LSTM + rate_scale q.(1, t, v, t^2, t v, v^2), a rate that
  falls as the thrust nears the throttle's steady thrust, at a speed that depends on both.
- 13, the published second-order structure (p250.py): the prior integrates its own thrust
  rate p (Euler, from its acceleration at the model's thrust) and the LSTM adds to it:
  g = LSTM + p[k],  p[k+1] = p[k] + Tddot(T[k], p[k], u[k]) dt.

This module holds the training-time form (flax variables); step.py holds the exported form the
simulator runs.
"""

from __future__ import annotations

from typing import Any

import flax.linen as nn
import jax
import jax.numpy as jnp
import numpy as np
from flax import struct

from motionkit.jet_ident.p250 import thrust_acceleration

Carry = tuple[jax.Array, ...]  # LSTM (c, h), and the prior's thrust rate p with a prior


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


FIRST_ORDER, SECOND_ORDER = 6, 13  # prior lengths


def first_order_terms(x: jax.Array) -> list[jax.Array]:
    """The six terms of the first-order prior at normalised inputs x [..., 2]."""
    t, v = x[..., 0], x[..., 1]
    return [t * 0 + 1, t, v, t * t, t * v, v * v]


def with_prior(
    prior: jax.Array | None,
    state: tuple[jax.Array, ...],
    x: jax.Array,
    rate_scale: float,
    dt: float,
    thrust: jax.Array,
    throttle: jax.Array,
) -> tuple[tuple[jax.Array, ...], jax.Array]:
    """The prior's next state (() or (p,)) and its thrust rate [N/s] at `state`."""
    if prior is None:
        return (), jnp.zeros_like(thrust)
    if prior.shape[-1] == FIRST_ORDER:
        terms = first_order_terms(x)
        return (), rate_scale * sum(prior[..., i] * terms[i] for i in range(FIRST_ORDER))
    (p,) = state
    return (p + thrust_acceleration(prior, thrust, p, throttle) * dt,), p


class ThrustLSTM(nn.Module):
    """One step: (carry, normalised inputs [..., 2]) -> (carry, normalised thrust rate [...])."""

    hidden: int

    @nn.compact
    def __call__(self, carry: Carry, inputs: jax.Array) -> tuple[Carry, jax.Array]:
        carry, h = nn.LSTMCell(self.hidden, name="cell")(carry, inputs)
        return carry, nn.Dense(1, name="head")(h)[..., 0]


def zero_carry(hidden: int, batch: tuple[int, ...] = (), prior: Any = None) -> Carry:
    """The zero state: LSTM (c, h), and p for a second-order prior."""
    zero = jnp.zeros((*batch, hidden))
    second = prior is not None and prior.shape[-1] == SECOND_ORDER
    return (zero, zero, jnp.zeros(batch)) if second else (zero, zero)


def init_variables(hidden: int, seed: int, prior: np.ndarray | None = None) -> dict[str, Any]:
    """Fresh flax variables; the head starts near zero (the thrust holds still at first), or at
    zero with a prior (the model is the prior alone)."""
    module = ThrustLSTM(hidden)
    variables = module.init(jax.random.key(seed), zero_carry(hidden), jnp.zeros(2))
    head = variables["params"]["head"]
    scale = 0.1 if prior is None else 0.0
    head = {"kernel": head["kernel"] * scale, "bias": jnp.zeros_like(head["bias"])}
    out: dict[str, Any] = {"params": {**variables["params"], "head": head}}
    if prior is not None:
        out["prior"] = jnp.asarray(prior, jnp.float32)
    return out


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
    x = norm.inputs(thrust, throttle)
    lstm, rate = ThrustLSTM(hidden).apply({"params": variables["params"]}, carry[:2], x)
    prior = variables.get("prior")
    state, prior_rate = with_prior(prior, carry[2:], x, norm.rate_scale, dt, thrust, throttle)
    return (*lstm, *state), thrust + (rate * norm.rate_scale + prior_rate) * dt


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
    carry = zero_carry(hidden, thrust.shape[:-1], variables.get("prior"))
    step = lambda carry, t, u: lstm_step(hidden, variables, norm, dt, carry, t, u)  # noqa: E731

    def forced(carry: Carry, sample: tuple[jax.Array, jax.Array]) -> tuple[Carry, None]:
        carry, _ = step(carry, *sample)
        return carry, None

    def free(state: tuple[Carry, jax.Array], u: jax.Array) -> tuple[Any, jax.Array]:
        carry, t = step(*state, u)
        return (carry, t), t

    thrust_t, throttle_t = jnp.moveaxis(thrust, -1, 0), jnp.moveaxis(throttle, -1, 0)
    carry, _ = jax.lax.scan(forced, carry, (thrust_t[: warmup - 1], throttle_t[: warmup - 1]))
    _, simulated = jax.lax.scan(free, (carry, thrust_t[warmup - 1]), throttle_t[warmup - 1 : -1])
    return jnp.moveaxis(simulated, 0, -1)
