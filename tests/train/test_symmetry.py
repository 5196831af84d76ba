"""The mirror on the trainer's arrays: the AMP features and the observation of a mirrored
state are the mirrored features and observation (computed by the environment itself, on
MJX), mirroring twice is the identity, the height map's rows are reversed, and the mirror loss
is zero for a policy that is its own mirror image and (d / std)^2 by hand otherwise."""

import jax.numpy as jnp
import mujoco
import numpy as np
import pytest

from motionkit.robot.mirror import robot_mirror
from motionkit.train.ppo import mirror_loss
from motionkit.train.symmetry import FeatureMirror, feature_mirror

mjx = pytest.importorskip("mujoco.mjx")


def _state(env, rng: np.random.Generator) -> mujoco.MjData:
    """A perturbed standing state, turned to a heading of 0.7 rad and moved off the origin."""
    model = env.mj_model
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, 0)
    data.qpos[:2] = [0.4, -0.3]
    data.qpos[3:7] = [np.cos(0.35), 0.0, 0.0, np.sin(0.35)]
    data.qpos[7:] += rng.uniform(-0.2, 0.2, model.nq - 7)
    data.qvel[:] = rng.normal(0.0, 0.3, model.nv)
    mujoco.mj_forward(model, data)
    return data


def _mirrored(env, data: mujoco.MjData) -> mujoco.MjData:
    mirror, model = robot_mirror(env.robot), env.mj_model
    other = mujoco.MjData(model)
    qpos, qvel = data.qpos, data.qvel
    other.qpos[:3], other.qpos[3:7] = mirror.vector(qpos[:3]), mirror.quaternion(qpos[3:7])
    other.qpos[7:] = mirror.joint_values(qpos[7:])
    other.qvel[:3], other.qvel[3:6] = mirror.vector(qvel[:3]), mirror.axial(qvel[3:6])
    other.qvel[6:] = mirror.joint_values(qvel[6:])
    mujoco.mj_forward(model, other)
    return other


def test_a_mirrored_state_has_the_mirrored_features_and_observation(env) -> None:
    """To 1 mm and 1e-3: the model's own asymmetry (the arm jets' frames differ by 2 cm across
    the plane in the public Mk1_1, the shoulders by millimetres); a wrong map is off by far
    more (the torso's flipped signs alone move the features by 0.1 or more)."""
    features = feature_mirror(env)
    rng = np.random.default_rng(1)
    data = _state(env, rng)
    other = _mirrored(env, data)
    thrust = jnp.array([10.0, 60.0, 120.0, 200.0])
    mirrored_thrust = thrust[np.asarray(features.mirror.jets)]
    target = jnp.array([1.5, 0.4, 0.6])
    mirror = robot_mirror(env.robot)
    mirrored_target = jnp.asarray(mirror.vector(np.asarray(target)))
    mx, mx_other = mjx.put_data(env.mj_model, data), mjx.put_data(env.mj_model, other)
    chi = env.features(mx, thrust)
    expected = env.features(mx_other, mirrored_thrust)
    assert np.abs(features.chi(chi) - expected).max() < 1e-3
    assert np.abs(chi - expected).max() > 0.1  # the mirror changed the features
    obs = env.observe(mx, thrust, target)
    assert (
        np.abs(features.obs(obs) - env.observe(mx_other, mirrored_thrust, mirrored_target)).max()
        < 1e-3
    )
    # twice: the identity
    assert np.allclose(features.chi(features.chi(chi)), chi, atol=1e-6)
    assert np.allclose(features.obs(features.obs(obs)), obs, atol=1e-6)
    actions = jnp.asarray(rng.uniform(-1, 1, env.action_size))
    assert np.allclose(features.actions(features.actions(actions)), actions)


def test_the_height_map_rows_across_the_facing_are_reversed(env) -> None:
    features = FeatureMirror(robot_mirror(env.robot), env.layout, (2, 3))
    heights = jnp.arange(6.0)  # 2 points along the facing x 3 across it
    obs = jnp.concatenate([jnp.zeros(env.layout.size), heights, jnp.zeros(3)])
    mirrored = features.obs(obs)[env.layout.size : -3]
    assert mirrored.tolist() == [2.0, 1.0, 0.0, 5.0, 4.0, 3.0]


def test_the_mirror_loss_by_hand() -> None:
    log_std = jnp.log(jnp.array([0.1, 0.2]))
    same = jnp.array([[0.3, -0.2]])
    assert float(mirror_loss(same, same, log_std)) == 0.0
    # differences 0.05 and 0.1 over stds 0.1 and 0.2: (0.5^2 + 0.5^2) / 2 = 0.25
    value = mirror_loss(jnp.array([[0.35, -0.1]]), same, log_std)
    assert float(value) == pytest.approx(0.25)


def test_mirrored_priors_hold_each_clip_twice(robot, prior_files) -> None:
    from motionkit.train.config import PriorConfig
    from motionkit.train.priors import load_priors

    priors = {"walk": PriorConfig((str(prior_files["walk"]),))}
    plain, summary = load_priors(priors, robot, 30.0)
    doubled, mirrored_summary = load_priors(priors, robot, 30.0, robot_mirror(robot))
    assert mirrored_summary["walk"]["pairs"] == 2 * summary["walk"]["pairs"]
    assert len(doubled.states.qpos) == 2 * len(plain.states.qpos)
    # the mirrored clip weighs as much as the clip: half the draws
    pairs = summary["walk"]["pairs"]
    assert float(doubled.cumulative[pairs - 1]) == pytest.approx(0.5, abs=1e-6)
    # the second half is the first mirrored: the base's sideways position changes sign
    half = len(plain.states.qpos)
    first, second = np.asarray(doubled.states.qpos[:half]), np.asarray(doubled.states.qpos[half:])
    assert np.allclose(second[:, 1], -first[:, 1], atol=1e-6)


@pytest.mark.slow
def test_a_run_with_the_mirror_logs_its_loss(config_with_priors, robot, tmp_path) -> None:
    from dataclasses import replace

    from motionkit.train.curves import read_table
    from motionkit.train.runner import train

    config = config_with_priors
    config = replace(
        config,
        ppo=replace(config.ppo, mirror_coef=1.0),
        amp=replace(config.amp, mirror=True),
        run=replace(config.run, iterations=3, checkpoint_every=3),
    )
    train(config, tmp_path, robot)
    log = read_table(tmp_path / "train.csv")
    assert np.all(np.isfinite(log["mirror_loss"])) and np.all(log["mirror_loss"] > 0)
