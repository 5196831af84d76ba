"""The simulator's jet step: `thrust_next(params, state, T, u) -> (state, T_next)`, pure JAX.

Two models share the interface (pick one by the type of `params`; the choice is made at trace
time, so both jit and vmap):

- `LSTMThrust`: the fitted LSTM (u = throttle [%]); state = the LSTM's (c, h).
- `IdealThrust`: the ideal jet of earlier iRonCub work, whose input is the thrust rate
  (u [N/s], clipped to +-rate_max); the thrust stays in [0, t_max]; state = ().

For a batch of environments: `jax.vmap(thrust_next, in_axes=(None, 0, 0, 0))`.
"""

from __future__ import annotations

from typing import Any

import jax
import jax.numpy as jnp
from flax import struct

from motionkit.jet_ident.model import Normalisation

GATES = ("i", "f", "g", "o")  # flax LSTMCell gate order: input, forget, cell, output


@struct.dataclass
class LSTMThrust:
    w_input: jax.Array  # (2, 4H): normalised (thrust, throttle) to the gates i, f, g, o
    w_hidden: jax.Array  # (H, 4H)
    bias: jax.Array  # (4H,)
    w_out: jax.Array  # (H,)
    b_out: jax.Array  # ()
    norm: Normalisation
    dt: float  # s

    @property
    def hidden(self) -> int:
        return self.w_hidden.shape[0]

    @classmethod
    def from_variables(
        cls, variables: dict[str, Any], norm: Normalisation, dt: float
    ) -> LSTMThrust:
        """Fuse the flax variables of model.ThrustLSTM into four arrays."""
        cell, head = variables["params"]["cell"], variables["params"]["head"]
        w_input = jnp.concatenate([cell[f"i{g}"]["kernel"] for g in GATES], axis=1)
        w_hidden = jnp.concatenate([cell[f"h{g}"]["kernel"] for g in GATES], axis=1)
        bias = jnp.concatenate([cell[f"h{g}"]["bias"] for g in GATES])
        return cls(w_input, w_hidden, bias, head["kernel"][:, 0], head["bias"][0], norm, dt)


@struct.dataclass
class IdealThrust:
    dt: float  # s
    t_max: float  # N, the robot's (its spec's)
    rate_max: float  # N/s


def thrust_next(params: LSTMThrust | IdealThrust, state: Any, thrust: jax.Array, u: jax.Array):
    """Next (state, thrust [N]) from the thrust [N] and the input `u` now (see the module doc)."""
    if isinstance(params, IdealThrust):
        rate = jnp.clip(u, -params.rate_max, params.rate_max)
        return state, jnp.clip(thrust + rate * params.dt, 0.0, params.t_max)
    c, h = state
    x = params.norm.inputs(thrust, u)
    z = x @ params.w_input + h @ params.w_hidden + params.bias
    i, f, g, o = jnp.split(z, 4, axis=-1)
    c = jax.nn.sigmoid(f) * c + jax.nn.sigmoid(i) * jnp.tanh(g)
    h = jax.nn.sigmoid(o) * jnp.tanh(c)
    rate = h @ params.w_out + params.b_out
    return (c, h), thrust + rate * params.norm.rate_scale * params.dt


def initial_state(
    params: LSTMThrust | IdealThrust, thrust: jax.Array, u: jax.Array, steps: int = 50
):
    """The state of a jet resting at `thrust` with input `u`: the LSTM is run `steps` times on
    these inputs from a zero state (as training warms it up). Scalar thrust and u; vmap for a
    batch."""
    if isinstance(params, IdealThrust):
        return ()
    zero = jnp.zeros(params.hidden)

    def warm(state: Any, _: None) -> tuple[Any, None]:
        state, _ = thrust_next(params, state, thrust, u)
        return state, None

    state, _ = jax.lax.scan(warm, (zero, zero), None, length=steps)
    return state


def free_run(
    params: LSTMThrust | IdealThrust, thrust: jax.Array, u: jax.Array, warmup: int
) -> jax.Array:
    """Simulated thrust for samples warmup..n-1 of a log: the first `warmup` samples feed the
    measured thrust, then the model feeds itself (as in training)."""
    state: Any = ()
    if isinstance(params, LSTMThrust):
        state = (jnp.zeros(params.hidden), jnp.zeros(params.hidden))

    def forced(state: Any, sample: tuple[jax.Array, jax.Array]) -> tuple[Any, None]:
        state, _ = thrust_next(params, state, *sample)
        return state, None

    def free(carry: tuple[Any, jax.Array], ui: jax.Array) -> tuple[Any, jax.Array]:
        state, t = thrust_next(params, *carry, ui)
        return (state, t), t

    state, _ = jax.lax.scan(forced, state, (thrust[: warmup - 1], u[: warmup - 1]))
    _, simulated = jax.lax.scan(free, (state, thrust[warmup - 1]), u[warmup - 1 : -1])
    return simulated


free_run_jit = jax.jit(free_run, static_argnames="warmup")
