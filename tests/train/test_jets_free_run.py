"""The environment's thrust under a throttle sequence is `motionkit.jet_ident`'s free run of the
same fitted model (`step.free_run`, which `jet-ident eval` scores models with), to float
rounding, on both physics backends (MuJoCo C and MJX).

The comparison runs at 50 Hz control: the model was fitted at 100 Hz (dt 0.01 s), and 1/50 s is
two of its steps, so the environment steps it at its own dt and its dead time (3 samples,
30 ms) stays 3 steps. At 30 Hz (the CPU recipes' rate) the environment steps the model 3 times
per control step at 1/90 s and rounds its dead time to those steps (3 x 0.9 = 2.7 -> 3 steps
of 1/90 s, 33 ms): another discretisation of the model than the one jet_ident runs, so the two
thrusts differ by more than rounding there (`test_other_control_rates_resample_the_model`).
"""

from dataclasses import replace

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from motionkit.jet_ident.model import Normalisation, init_variables
from motionkit.jet_ident.p250 import P250_COEFFS
from motionkit.jet_ident.step import LSTMThrust, free_run, initial_state
from motionkit.train.config import EnvConfig
from motionkit.train.env.jets import Jets

slow = pytest.mark.slow  # compiles MJX's step for the LSTM jets (about a minute on 2 cores)

HZ, FLOOR, WARMUP = 50.0, 15.0, 51  # WARMUP - 1 = 50: initial_state's warm-up steps
# throttle [%] per control step: idle, a step up to 50 % (four jets stay below the robot's
# weight: it stays on its feet), a step down to 25 %
THROTTLES = np.repeat([FLOOR, 50.0, 25.0], [5, 25, 30])


def fitted_model() -> LSTMThrust:
    """A stand-in for a fitted model: an LSTM on the published second-order P250 prior with a
    30 ms dead time and its output layer nonzero, so that both parts drive the thrust."""
    variables = init_variables(8, 0, P250_COEFFS)
    head = variables["params"]["head"]
    kernel = 0.05 * jax.random.normal(jax.random.key(3), head["kernel"].shape)
    variables["params"]["head"] = {"kernel": kernel, "bias": head["bias"] + 0.02}
    norm = Normalisation(108.309, 65.793, 47.333, 31.483, 65.793)
    return LSTMThrust.from_variables(variables, norm, 0.01, delay=3)


def reference(model: LSTMThrust, idle: float) -> np.ndarray:
    """jet_ident's free run: a jet idling (at `idle` under the floor throttle, WARMUP - 1
    samples feed it), then THROTTLES, each held for the two model steps of a control step; the
    thrust after each control step (every second sample)."""
    sub = np.repeat(THROTTLES, 2)
    throttle = np.concatenate([np.full(WARMUP - 1, FLOOR), sub, [0.0]])
    thrust = np.full_like(throttle, idle)  # measured thrust: read only in the warm-up
    simulated = free_run(model, jnp.asarray(thrust), jnp.asarray(throttle), WARMUP)
    return np.asarray(simulated)[1::2]


def jet_config(tiny_config, impl: str) -> EnvConfig:
    return replace(
        tiny_config.env, jet="lstm", jet_model="unused.npz", throttle_min=FLOOR,
        control_hz=HZ, joint_noise=0.0, impl=impl,
    )  # fmt: skip


def actions(env) -> np.ndarray:
    """(steps, 1, actions): the standing posture, the jets' action of each throttle."""
    jets = 2.0 * (THROTTLES - FLOOR) / (100.0 - FLOOR) - 1.0
    rest = np.asarray(env.rest_action, np.float32)
    out = np.tile(rest, (len(THROTTLES), 1, 1))
    out[:, 0, env.num_joints :] = jets[:, None]
    return out


def idling(env, state):
    """`state` (a batch of one) with its jets idling: at the floor's steady thrust, the model
    warmed up there under the floor throttle (the state `Jets.state_at` tabulates, exactly)."""
    idle = jnp.full(env.num_jets, env.jets.idle, jnp.float32)
    rest = jax.vmap(lambda t: initial_state(env.jets.params, t, jnp.asarray(FLOOR)))(idle)
    return state.replace(thrust=idle[None], jet=jax.tree.map(lambda x: x[None], rest))


def check(thrusts: list[np.ndarray], done: list[bool], env) -> None:
    assert not any(done)  # one episode: no reset in between
    idle = env.jets.idle
    expected = reference(env.jets.params, idle)
    got = np.stack(thrusts)[:, 0]  # (steps, jets): the four jets alike
    np.testing.assert_allclose(got, np.repeat(expected[:, None], 4, axis=1), rtol=2e-5, atol=2e-4)
    # the model idles, answers the step up only after its dead time (the first control step
    # at 50 % is 2 of its 3 late samples), rises, and turns down after the step down
    np.testing.assert_allclose(expected[:6], idle, atol=0.5)
    assert expected[29] > idle + 20.0 and expected[-1] < expected.max()


def test_the_model_steps_at_its_own_rate_here(robot, tiny_config) -> None:
    from motionkit.train.env import Env

    env = Env(robot, jet_config(tiny_config, "mujoco"), jet_model=fitted_model())
    assert env.jets.steps == 2 and env.jets.params.dt == 0.01 and env.jets.params.delay == 3


def run_actions(env, state, step) -> tuple[list[np.ndarray], list[bool]]:
    """The thrust after each step of `actions(env)` from `state`, and whether it ended."""
    thrusts, done = [], []
    for action in actions(env):
        state, info = step(state, jnp.asarray(action))
        thrusts.append(np.asarray(state.thrust))
        done.append(bool(info.done[0]))
    return thrusts, done


@slow
def test_mujoco_backend_thrust_is_the_free_run(robot, tiny_config) -> None:
    from motionkit.train.env import Env
    from motionkit.train.env.mujoco import BatchPhysics, stepper

    model = fitted_model()
    env = Env(robot, jet_config(tiny_config, "mujoco"), jet_model=model)
    physics = BatchPhysics(env, 1, threads=1)
    step = stepper(env, [physics])
    state = idling(env, physics.reset(jax.random.split(jax.random.key(0), 1)))
    check(*run_actions(env, state, step), env)


@slow
def test_mjx_backend_thrust_is_the_free_run(robot, tiny_config) -> None:
    from motionkit.train.env import Env

    model = fitted_model()
    env = Env(robot, jet_config(tiny_config, "jax"), jet_model=model)
    reset, step = jax.jit(jax.vmap(env.reset)), jax.jit(jax.vmap(env.step))
    state = idling(env, reset(jax.random.split(jax.random.key(0), 1)))
    check(*run_actions(env, state, step), env)


def test_other_control_rates_resample_the_model() -> None:
    """At 30 Hz: 3 steps of 1/90 s per control step; a dead time of 3 samples of 0.01 s is
    round(2.7) = 3 steps, one of 12 (0.12 s, jet-ident's longest) round(10.8) = 11."""
    config = EnvConfig(control_hz=30.0, jet="lstm", jet_model="unused.npz", throttle_min=FLOOR)
    short = Jets(config, np.full(4, 250.0), fitted_model())
    assert short.steps == 3 and short.params.dt == pytest.approx(1 / 90)
    assert short.params.delay == 3
    long = Jets(config, np.full(4, 250.0), fitted_model().replace(delay=12))
    assert long.params.delay == 11
