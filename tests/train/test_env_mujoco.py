"""The MuJoCo C backend (`mujoco.batch`): the same physics as plain MuJoCo bit for bit, the same
task as MJX within the documented contact difference, resets of the ended environments only,
and rollouts that reproduce themselves at any thread count."""

from dataclasses import replace

import jax
import jax.numpy as jnp
import mujoco
import numpy as np
import pytest

slow = pytest.mark.slow  # compiles the task and MJX (about a minute on 2 cores)

BATCH = 4


@pytest.fixture(scope="module")
def quiet_config(tiny_config):
    """The tiny recipe without joint noise at reset: the PD forces of a standing start stay
    below the actuators' force limits, where MJX and MuJoCo agree (test_play.py)."""
    return replace(tiny_config, env=replace(tiny_config.env, joint_noise=0.0))


@pytest.fixture(scope="module")
def mujoco_env(robot, quiet_config):
    from motionkit.train.env import Env

    return Env(robot, replace(quiet_config.env, impl="mujoco"), quiet_config.reward)


@pytest.fixture(scope="module")
def mjx_env(robot, quiet_config):
    from motionkit.train.env import Env

    return Env(robot, replace(quiet_config.env, impl="jax"), quiet_config.reward)


def _physics(env, threads: int = 2):
    from motionkit.train.env.mujoco import BatchPhysics, stepper

    physics = BatchPhysics(env, BATCH, threads=threads)
    return physics, stepper(env, [physics])


def _actions(env, noise: float, steps: int, seed: int = 0) -> list[jax.Array]:
    rng = np.random.default_rng(seed)
    rest = np.asarray(env.rest_action)
    shape = (BATCH, env.action_size)
    return [
        jnp.asarray(rest + noise * rng.standard_normal(shape), jnp.float32) for _ in range(steps)
    ]


def test_auto_is_mujoco_on_a_cpu(robot, tiny_config) -> None:
    from motionkit.train.devices import resolve_impl
    from motionkit.train.env import Env

    assert tiny_config.env.impl == "auto" and resolve_impl("auto") == "mujoco"
    assert resolve_impl("jax") == "jax" and resolve_impl("warp") == "warp"
    env = Env(robot, tiny_config.env, tiny_config.reward)
    assert env.config.impl == "mujoco" and env.mx is None


@slow
def test_the_batch_steps_as_plain_mujoco_bit_for_bit(mujoco_env) -> None:
    """Ten control steps of the backend against mj_step on one MjData per environment, from
    the same reset and under the same controls: identical float64 positions."""
    physics, step = _physics(mujoco_env)
    state = physics.reset(jax.random.split(jax.random.key(1), BATCH))
    model = mujoco_env.mj_model
    datas = []
    for k in range(BATCH):
        data = mujoco.MjData(model)
        mujoco.mj_resetDataKeyframe(model, data, model.key("stand").id)
        data.qpos[:] = physics.fields["qpos"][k]
        mujoco.mj_kinematics(model, data)
        datas.append(data)
    control = jax.jit(jax.vmap(mujoco_env.control))
    for action in _actions(mujoco_env, 0.3, 10):
        ctrl = np.asarray(control(state, action)[0])
        state, info = step(state, action)
        assert not np.asarray(info.done).any()
        for k, data in enumerate(datas):
            data.ctrl[:] = ctrl[k]
            mujoco.mj_step(model, data, nstep=mujoco_env.config.substeps)
            np.testing.assert_array_equal(physics.fields["qpos"][k], data.qpos)
    # the task's float32 view is the batch's state
    np.testing.assert_array_equal(state.data.qpos, physics.fields["qpos"].astype(np.float32))


def _parity(mjx_env, mujoco_env, lift: float, noise: float) -> dict[str, float]:
    """Largest differences over 10 control steps between the MJX and MuJoCo backends from the
    same reset raised by `lift` [m], under the same actions."""
    from motionkit.train.env.mjx import mjx

    keys = jax.random.split(jax.random.key(3), BATCH)
    state_mjx = jax.jit(jax.vmap(mjx_env.reset))(keys)
    raised = state_mjx.data.replace(qpos=state_mjx.data.qpos.at[:, 2].add(lift))
    data = jax.vmap(lambda d: mjx.kinematics(mjx_env.mx, d))(raised)
    observe = jax.vmap(mjx_env.observe)
    state_mjx = state_mjx.replace(data=data, obs=observe(data, state_mjx.thrust, state_mjx.target))
    physics, step = _physics(mujoco_env)
    state = physics.reset(keys)
    kinematics = physics.place(np.arange(BATCH), np.asarray(data.qpos), np.asarray(data.qvel))
    state = state.replace(data=kinematics, obs=observe(kinematics, state.thrust, state.target))
    worst = {"obs": float(jnp.abs(state.obs - state_mjx.obs).max()), "base": 0.0, "joints": 0.0}
    worst |= {"reward": 0.0}
    step_mjx = jax.jit(jax.vmap(mjx_env.step))
    for action in _actions(mujoco_env, noise, 10):
        state_mjx, info_mjx = step_mjx(state_mjx, action)
        state, info = step(state, action)
        assert not np.asarray(info.done).any() and not np.asarray(info_mjx.done).any()
        for name, ours, theirs in (
            ("base", state.data.qpos[:, :3], state_mjx.data.qpos[:, :3]),
            ("joints", state.data.qpos[:, 7:], state_mjx.data.qpos[:, 7:]),
            ("obs", state.obs, state_mjx.obs),
            ("reward", info.task_reward, info_mjx.task_reward),
        ):
            worst[name] = max(worst[name], float(jnp.abs(ours - theirs).max()))
    return worst


@slow
def test_parity_with_mjx_in_the_air(mjx_env, mujoco_env) -> None:
    """Off the ground and below the force limits the backends agree to float32 rounding, as
    play's MuJoCo loop and MJX do (measured: base 6e-8 m, joints 6e-8 rad, observation 2e-6)."""
    worst = _parity(mjx_env, mujoco_env, lift=0.3, noise=0.005)
    assert worst["base"] < 1e-5 and worst["joints"] < 1e-5 and worst["obs"] < 3e-4, worst
    assert worst["reward"] < 1e-5, worst


@slow
def test_parity_with_mjx_on_the_ground(mjx_env, mujoco_env) -> None:
    """Standing, within the contact difference test_play.py documents for MuJoCo against MJX
    (base 2e-3 m, joints 2e-2 rad, observation 1.0 over 10 steps)."""
    worst = _parity(mjx_env, mujoco_env, lift=-0.001, noise=0.0)
    assert worst["base"] < 2e-3 and worst["joints"] < 2e-2 and worst["obs"] < 1.0, worst


@slow
def test_only_the_ended_environments_restart(mujoco_env, mjx_env) -> None:
    """Env 1 falls (its base put at 0.3 m); the others go on. Env 1 restarts where MJX's
    `Env.reset` of the same pose would, and the batch's other rows are untouched by the reset."""
    physics, _ = _physics(mujoco_env)
    state = physics.reset(jax.random.split(jax.random.key(5), BATCH))
    physics.fields["qpos"][1, 2] = 0.3
    physics.batch.forward(np.array([1]), stage=mujoco.mjtStage.mjSTAGE_POS)
    state = state.replace(data=physics.kinematics())
    control = jax.jit(jax.vmap(mujoco_env.control))
    advance = jax.jit(jax.vmap(mujoco_env.advance))
    action = _actions(mujoco_env, 0.0, 1)[0]
    ctrl, jet, thrust = control(state, action)
    stepped, info, pose = advance(state, physics.step(ctrl), jet, thrust)
    before = physics.fields["qpos"].copy()
    assert np.asarray(info.done).tolist() == [False, True, False, False]
    after = physics.restart(stepped, pose, np.asarray(info.done))
    np.testing.assert_array_equal(physics.fields["qpos"][[0, 2, 3]], before[[0, 2, 3]])
    assert np.asarray(after.steps).tolist() == [1, 0, 1, 1]
    one = jax.tree.map(lambda x: x[1], pose)
    expected = jax.jit(mjx_env._start_mjx)(one)
    np.testing.assert_allclose(after.obs[1], expected.obs, atol=1e-5)
    np.testing.assert_array_equal(after.target[1], expected.target)
    np.testing.assert_allclose(physics.fields["qpos"][1], np.asarray(one.qpos), atol=1e-7)
    for name in ("obs", "target", "steps"):
        np.testing.assert_array_equal(
            np.asarray(getattr(after, name))[[0, 2, 3]],
            np.asarray(getattr(stepped, name))[[0, 2, 3]],
        )


@slow
def test_a_seeded_rollout_reproduces_itself_at_1_and_2_threads(robot, tiny_config) -> None:
    """Two trainers of one seed, one with a single physics thread: bit-identical rollouts,
    episodes ending and restarting included."""
    from motionkit.train.env.mujoco import BatchPhysics
    from motionkit.train.learner import Trainer
    from motionkit.train.runner import make_env

    config = replace(tiny_config, env=replace(tiny_config.env, episode_seconds=0.2))
    rollouts = []
    for threads in (1, 2):
        trainer = Trainer(config, make_env(config, robot))
        trainer.physics = [
            BatchPhysics(trainer.env, config.ppo.num_envs, threads, index=k) for k in range(2)
        ]
        trainer.reset = trainer.physics[0].reset
        assert trainer.physics[0].batch.nthread == threads
        learner, carry = trainer.init(0)
        _, batch = trainer.rollout(learner, carry.env, jax.random.key(1), jnp.array(1.0))
        rollouts.append(batch)
    assert int(rollouts[0].info.done.sum()) >= config.ppo.num_envs  # every episode restarted
    leaves = [jax.tree.leaves(batch) for batch in rollouts]
    for ours, theirs in zip(*leaves, strict=True):
        np.testing.assert_array_equal(ours, theirs)
