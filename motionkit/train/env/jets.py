"""The environment's jets: the model that steps them (the ideal jet, or the fitted LSTM or grey
box, through `motionkit.jet_ident.step.thrust_next`), its idle thrust, and the model state of a
jet resting at a given thrust, so that an episode can start mid-flight.

Actions in [-1, 1] map to the jet input: the ideal jet's thrust rate a * thrust_rate_max
(jet_action "rate") or its thrust set point (a + 1) / 2 * T_max, approached at up to
thrust_rate_max ("thrust"), or the fitted model's throttle u = u_min + (100 - u_min) (a + 1) / 2
[%] with u_min = throttle_min (0: 50 + 50 a). The rest action holds the thrust (rate) or sets
it to 0 (set point), or the throttle to its floor u_min (the fitted models idle there: their
idle thrust is the steady thrust at the floor).
"""

from __future__ import annotations

from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

from motionkit.jet_ident.step import (
    GreyBoxThrust,
    IdealThrust,
    LSTMThrust,
    initial_state,
    thrust_next,
    zero_state,
)
from motionkit.train.config import EnvConfig

# % at which the model's steady thrust is tabulated (from the floor, throttle_min, to 100 %
# in as many steps: `Jets.throttles`)
THROTTLES = np.linspace(0.0, 100.0, 21)
TABLE_SIZE = 64  # thrusts at which the resting model state is tabulated
SETTLE_SECONDS = 30.0  # long enough for the thrust of a P250 model to settle


# The share of T_max above idle that the discriminator does not see: the thrust the policy's
# action noise leaves on its jets (about 1 N) would otherwise mark its walking as unlike the
# walking prior's (0 N). In a CPU walking run the thrust columns' normalised spread was 5e-4 to
# 6e-3 of T_max, and 0.01 T_max on every jet lowered that discriminator's mean logit on prior
# pairs from 1.01 to 0.41 (a clue it used, though not the one that kept its accuracy at 1.00).
THRUST_DEADBAND = 0.02


class Jets:
    """The jets of one robot (same model for every jet, each with its own T_max)."""

    def __init__(
        self, config: EnvConfig, t_max: np.ndarray, model: LSTMThrust | GreyBoxThrust | None
    ) -> None:
        self.config = config
        self.t_max = jnp.asarray(t_max, jnp.float32)
        self.count = len(t_max)
        if config.jet != "ideal":
            if model is None:
                raise ValueError(f"jet = '{config.jet}' needs the fitted model (jet_model)")
            self.steps = max(1, round(config.control_dt / model.dt))
            self.params: Any = model.replace(dt=config.control_dt / self.steps)
            if isinstance(model, LSTMThrust):  # the same dead time at the new step
                self.params = self.params.replace(
                    delay=round(model.delay * model.dt / self.params.dt)
                )
            self.floor = config.throttle_min
            self.throttles = np.linspace(self.floor, 100.0, len(THROTTLES))
            steady = np.maximum.accumulate(self._steady_thrust(self.throttles))
            self.idle = float(max(steady[0], 0.0))  # the steady thrust at the floor
            self.rest_action = -1.0  # the floor
            self._table = self._resting_states(steady)
        else:
            self.steps = 1
            self.params = IdealThrust(
                dt=config.control_dt, t_max=float(np.max(t_max)), rate_max=config.thrust_rate_max
            )
            self.floor, self.throttles = 0.0, None
            self.idle = 0.0
            self.rest_action = 0.0 if config.jet_action == "rate" else -1.0  # hold, or 0 N
            self._table = None

    @property
    def fitted(self) -> bool:
        """Whether the jets are a fitted model (LSTM or grey box) driven by a throttle."""
        return not isinstance(self.params, IdealThrust)

    def throttle(self, action: jax.Array) -> jax.Array:
        """The fitted models' throttle [%] of jet actions in [-1, 1]: the floor at -1, 100 at
        1, linear between."""
        return self.floor + (100.0 - self.floor) * (action + 1.0) / 2.0

    def command_share(self, action: jax.Array, thrust: jax.Array) -> jax.Array:
        """The jets' command per jet as a share of its range above rest, in [0, 1]: the
        throttle above the floor (fitted jets) or the thrust set point per T_max (ideal jet,
        jet_action "thrust"). The ideal jet's rate action sets no level: its thrust per
        T_max instead."""
        if not self.fitted and self.config.jet_action == "rate":
            return thrust / self.t_max
        return (jnp.clip(action, -1.0, 1.0) + 1.0) / 2.0

    def _steady_thrust(self, throttles: np.ndarray) -> np.ndarray:
        """The thrust [N] the model settles at under each constant throttle, from rest."""
        params, top = self.params, float(jnp.max(self.t_max))
        length = round(SETTLE_SECONDS / params.dt)

        def settle(u: jax.Array) -> jax.Array:
            def one(carry: tuple, _: None) -> tuple[tuple, None]:
                state, thrust = thrust_next(params, *carry, u)
                return (state, jnp.clip(thrust, 0.0, top)), None

            (_, thrust), _ = jax.lax.scan(one, (zero_state(params), jnp.zeros(())), None, length)
            return thrust

        return np.asarray(jax.jit(jax.vmap(settle))(jnp.asarray(throttles, jnp.float32)))

    def _resting_states(self, steady: np.ndarray) -> tuple[jax.Array, ...]:
        """(thrusts, *state): the model state of a jet resting at each tabulated thrust, under
        the throttle that holds it there (from the steady-state curve `steady` at
        `self.throttles`); a thrust at or below the floor's steady thrust rests at the floor."""
        thrusts = np.linspace(0.0, float(jnp.max(self.t_max)), TABLE_SIZE)
        # at or below idle the jet rests at the floor; where the curve is flat, within the
        # flat part
        held = np.interp(thrusts, steady, self.throttles)
        throttles = np.where(thrusts <= steady[0], self.floor, held)
        rest = jax.vmap(lambda t, u: initial_state(self.params, t, u))
        states = rest(jnp.asarray(thrusts, jnp.float32), jnp.asarray(throttles, jnp.float32))
        return (jnp.asarray(thrusts, jnp.float32), *states)

    def state_at(self, thrust: jax.Array) -> Any:
        """The model state of jets (jets,) resting at `thrust` [N] (linear in the table)."""
        if self._table is None:
            return ()
        thrusts, *states = self._table
        position = jnp.clip(thrust / thrusts[1], 0.0, TABLE_SIZE - 1.0)
        low = jnp.floor(position).astype(jnp.int32)
        high = jnp.minimum(low + 1, TABLE_SIZE - 1)
        w = position - low

        def lerp(table: jax.Array) -> jax.Array:
            weight = w.reshape(w.shape + (1,) * (table.ndim - 1))
            return (1 - weight) * table[low] + weight * table[high]

        return tuple(lerp(table) for table in states)

    def step(self, state: Any, thrust: jax.Array, action: jax.Array) -> tuple[Any, jax.Array]:
        """One control step of every jet: (model state, thrust [N]) after `action` (jets,)."""
        if isinstance(self.params, IdealThrust) and self.config.jet_action == "rate":
            u = action * self.config.thrust_rate_max
        elif isinstance(self.params, IdealThrust):  # the rate toward the set point (clipped)
            u = ((action + 1.0) / 2.0 * self.t_max - thrust) / self.params.dt
        else:
            u = self.throttle(action)
        per_jet = jax.vmap(thrust_next, in_axes=(None, 0, 0, 0))
        for _ in range(self.steps):
            state, thrust = per_jet(self.params, state, thrust, u)
        return state, jnp.clip(thrust, 0.0, self.t_max)

    def feature(self, thrust: jax.Array) -> jax.Array:
        """Thrust as the AMP features see it: above idle plus THRUST_DEADBAND x T_max, per T_max.
        A jet that is off (0 N in a walking clip), one idling (a fitted model cannot go below
        idle) and one a few newtons above (the policy's exploration noise) look alike."""
        return jnp.maximum(thrust - self.idle - THRUST_DEADBAND * self.t_max, 0.0) / self.t_max
