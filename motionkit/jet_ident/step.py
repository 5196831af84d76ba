"""The simulator's jet step: `thrust_next(params, state, T, u) -> (state, T_next)`, pure JAX.

Three models share the interface (pick one by the type of `params`; the choice is made at
trace time, so all jit and vmap):

- `LSTMThrust`: the fitted LSTM (u = throttle [%]); state = the LSTM's (c, h), the prior's
  thrust rate p [N/s] where the LSTM rides on a second-order prior (model.py), and the last
  `delay` throttles where the model sees the throttle that many steps late (the engine's dead
  time: ECU, fuel system and load cell).
- `GreyBoxThrust`: the grey box fitted beside it (the published second-order structure,
  p250.py), `substeps` RK4 steps per step with the throttle held (u = throttle [%]);
  state = (Tdot,), the thrust rate [N/s].
- `IdealThrust`: the ideal jet of earlier iRonCub work, whose input is the thrust rate
  (u [N/s], clipped to +-rate_max); the thrust stays in [0, t_max]; state = ().

For a batch of environments: `jax.vmap(thrust_next, in_axes=(None, 0, 0, 0))`.
"""

from __future__ import annotations

from typing import Any

import jax
import jax.numpy as jnp
from flax import struct

from motionkit.jet_ident.integrate import rk4
from motionkit.jet_ident.model import SECOND_ORDER, Normalisation, with_prior
from motionkit.jet_ident.p250 import thrust_acceleration

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
    prior: jax.Array | None = None  # (6,) or (13,): the prior's coefficients (model.py)
    delay: int = struct.field(pytree_node=False, default=0)  # steps the throttle is late

    @property
    def hidden(self) -> int:
        return self.w_hidden.shape[0]

    def zero_state(self) -> tuple[jax.Array, ...]:
        zero = jnp.zeros(self.hidden)
        second = self.prior is not None and self.prior.shape[-1] == SECOND_ORDER
        state = (zero, zero, jnp.zeros(())) if second else (zero, zero)
        return (*state, jnp.zeros(self.delay)) if self.delay else state

    @classmethod
    def from_variables(
        cls, variables: dict[str, Any], norm: Normalisation, dt: float, delay: int = 0
    ) -> LSTMThrust:
        """Fuse the flax variables of model.ThrustLSTM into four arrays (and the prior's)."""
        cell, head = variables["params"]["cell"], variables["params"]["head"]
        w_input = jnp.concatenate([cell[f"i{g}"]["kernel"] for g in GATES], axis=1)
        w_hidden = jnp.concatenate([cell[f"h{g}"]["kernel"] for g in GATES], axis=1)
        bias = jnp.concatenate([cell[f"h{g}"]["bias"] for g in GATES])
        out = head["kernel"][:, 0], head["bias"][0]
        return cls(w_input, w_hidden, bias, *out, norm, dt, variables.get("prior"), delay)


@struct.dataclass
class GreyBoxThrust:
    coeffs: jax.Array  # (13,) c0..c12 in the published normalisation
    dt: float  # s
    substeps: int = struct.field(pytree_node=False, default=10)


@struct.dataclass
class IdealThrust:
    dt: float  # s
    t_max: float  # N, the robot's (its spec's)
    rate_max: float  # N/s


Params = LSTMThrust | GreyBoxThrust | IdealThrust


def thrust_next(params: Params, state: Any, thrust: jax.Array, u: jax.Array):
    """Next (state, thrust [N]) from the thrust [N] and the input `u` now (see the module doc).

    One step of `params.dt`; pure JAX, so it jits and vmaps (a batch:
    `jax.vmap(thrust_next, in_axes=(None, 0, 0, 0))`).

    Args:
        params: the model: LSTMThrust, GreyBoxThrust or IdealThrust.
        state: the model's state (`initial_state`, or the last call's).
        thrust: the thrust now [N], a scalar.
        u: the input now, a scalar: throttle [%] (LSTM, grey box) or thrust rate [N/s]
            (ideal jet).

    Returns:
        (state, thrust): the state and the thrust [N] one step later.
    """
    if isinstance(params, IdealThrust):
        rate = jnp.clip(u, -params.rate_max, params.rate_max)
        return state, jnp.clip(thrust + rate * params.dt, 0.0, params.t_max)
    if isinstance(params, GreyBoxThrust):
        slope = lambda s: jnp.stack(  # noqa: E731
            [s[1], thrust_acceleration(params.coeffs, s[0], s[1], u)]
        )
        x = jnp.stack([thrust, state[0]])
        for _ in range(params.substeps):
            x = rk4(slope, x, params.dt / params.substeps)
        return (x[1],), x[0]
    if params.delay:  # the throttle `delay` steps ago drives the model; u joins the queue
        *state, queue = state
        late = jnp.asarray(u, queue.dtype)[..., None]
        u, queue = queue[..., 0], jnp.concatenate([queue[..., 1:], late], axis=-1)
    c, h = state[:2]
    x = params.norm.inputs(thrust, u)
    z = x @ params.w_input + h @ params.w_hidden + params.bias
    i, f, g, o = jnp.split(z, 4, axis=-1)
    c = jax.nn.sigmoid(f) * c + jax.nn.sigmoid(i) * jnp.tanh(g)
    h = jax.nn.sigmoid(o) * jnp.tanh(c)
    rate = (h @ params.w_out + params.b_out) * params.norm.rate_scale
    scale, dt = params.norm.rate_scale, params.dt
    prior, prior_rate = with_prior(params.prior, tuple(state[2:]), x, scale, dt, thrust, u)
    new = (c, h, *prior, queue) if params.delay else (c, h, *prior)
    return new, thrust + (rate + prior_rate) * dt


def zero_state(params: Params) -> tuple[jax.Array, ...]:
    """The state every free run starts from (the LSTM's before its warm-up)."""
    if isinstance(params, IdealThrust):
        return ()
    if isinstance(params, GreyBoxThrust):
        return (jnp.zeros(()),)
    return params.zero_state()


def initial_state(params: Params, thrust: jax.Array, u: jax.Array, steps: int = 50):
    """The state of a jet resting at `thrust` with input `u`.

    The LSTM is run `steps` times on these inputs from a zero state (as training warms it
    up); the grey box rests (Tdot = 0), the ideal jet has no state. Scalar thrust and u; vmap
    for a batch.

    Args:
        params: the model: LSTMThrust, GreyBoxThrust or IdealThrust.
        thrust: the resting thrust [N], a scalar.
        u: the input, a scalar: throttle [%] (LSTM, grey box) or thrust rate [N/s] (ideal).
        steps: the LSTM's warm-up steps.

    Returns:
        The state for `thrust_next`: the LSTM's (c, h, ...), (Tdot,) of the grey box, or ().
    """
    if not isinstance(params, LSTMThrust):
        return zero_state(params)

    def warm(state: Any, _: None) -> tuple[Any, None]:
        state, _ = thrust_next(params, state, thrust, u)
        return state, None

    state, _ = jax.lax.scan(warm, zero_state(params), None, length=steps)
    return state


def free_run(params: Params, thrust: jax.Array, u: jax.Array, warmup: int) -> jax.Array:
    """Simulated thrust for samples warmup..n-1 of a log.

    The first `warmup` samples feed the measured thrust, then the model feeds itself (as in
    training; the grey box starts at rest, as its baseline does).

    Args:
        params: the model: LSTMThrust, GreyBoxThrust or IdealThrust.
        thrust: the measured thrust [N], shape (n,).
        u: the input at each sample, shape (n,): throttle [%] (or thrust rate [N/s]).
        warmup: the samples fed the measured thrust (static under jit; at least 1).

    Returns:
        The simulated thrust [N] of samples warmup..n-1, shape (n - warmup,).
    """
    state = zero_state(params)
    if isinstance(params, GreyBoxThrust):  # nothing to warm: from rest at sample warmup - 1
        thrust, u, warmup = thrust[warmup - 1 :], u[warmup - 1 :], 1

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
