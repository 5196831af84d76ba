"""The discriminator's loss and gradient penalty (hand values, finite differences), the replay
buffer, prior sampling, and the simulator's AMP features against motionkit.dataset's."""

import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from motionkit.train import amp


@pytest.fixture(scope="module")
def small_disc():
    disc = amp.Discriminator((16, 16))
    x = jnp.zeros((1, 3))
    params = disc.init(jax.random.key(1), x, x)
    return disc, params


def test_bce_against_hand_values() -> None:
    loss = amp.bce_loss(jnp.array([0.0, 2.0]), jnp.array([0.0, -1.0]))
    sig = lambda z: 1 / (1 + math.exp(-z))  # noqa: E731
    expert = -(math.log(sig(0.0)) + math.log(sig(2.0))) / 2
    policy = -(math.log(1 - sig(0.0)) + math.log(1 - sig(-1.0))) / 2
    assert float(loss) == pytest.approx(0.5 * (expert + policy), rel=1e-6)


def test_gradient_penalty_against_finite_differences(small_disc) -> None:
    disc, params = small_disc
    rng = np.random.default_rng(0)
    current, following = rng.normal(size=(4, 3)), rng.normal(size=(4, 3))
    with jax.enable_x64(True):
        params64 = jax.tree.map(lambda p: jnp.asarray(p, jnp.float64), params)
        penalty = amp.gradient_penalty(
            disc.apply, params64, jnp.asarray(current), jnp.asarray(following)
        )
        d = lambda c, f: float(disc.apply(params64, jnp.asarray(c), jnp.asarray(f)))  # noqa: E731
        eps, squares = 1e-6, []
        for c, f in zip(current, following, strict=True):
            x = np.concatenate([c, f])
            grad = []
            for i in range(6):
                step = np.zeros(6)
                step[i] = eps
                hi, lo = x + step, x - step
                grad.append((d(hi[:3], hi[3:]) - d(lo[:3], lo[3:])) / (2 * eps))
            squares.append(np.sum(np.square(grad)))
    assert float(penalty) == pytest.approx(np.mean(squares), rel=1e-6)


def test_discriminator_loss_gradient_against_finite_differences(small_disc) -> None:
    disc, params = small_disc
    rng = np.random.default_rng(1)
    with jax.enable_x64(True):
        params64 = jax.tree.map(lambda p: jnp.asarray(p, jnp.float64), params)
        expert = tuple(jnp.asarray(rng.normal(size=(8, 3))) for _ in range(2))
        policy = tuple(jnp.asarray(rng.normal(size=(8, 3)) + 1.0) for _ in range(2))

        def loss(p):
            return amp.discriminator_loss(p, disc.apply, expert, policy, 5.0, 0.05, 1e-2)[0]

        grads = jax.grad(loss)(params64)
        leaves, tree = jax.tree.flatten(params64)
        direction = [jnp.asarray(rng.normal(size=leaf.shape)) for leaf in leaves]
        along = sum(jnp.sum(g * v) for g, v in zip(jax.tree.leaves(grads), direction, strict=True))
        eps = 1e-6
        shifted = lambda s: jax.tree.unflatten(  # noqa: E731
            tree, [leaf + s * v for leaf, v in zip(leaves, direction, strict=True)]
        )
        numeric = (loss(shifted(eps)) - loss(shifted(-eps))) / (2 * eps)
    assert float(along) == pytest.approx(float(numeric), rel=1e-5)


def test_discriminator_loss_parts(small_disc) -> None:
    disc, params = small_disc
    x = jnp.ones((2, 3))
    _, parts = amp.discriminator_loss(params, disc.apply, (x, x), (x, x), 0.0, 0.0)
    logit = float(disc.apply(params, x, x)[0])
    assert float(parts["disc_loss"]) == pytest.approx(
        0.5 * (math.log1p(math.exp(-logit)) + math.log1p(math.exp(logit))), rel=1e-5
    )
    assert float(parts["disc_expert_accuracy"]) + float(parts["disc_policy_accuracy"]) == 1.0


def test_logit_regularisation_and_weight_decay_against_hand_values(small_disc) -> None:
    disc, params = small_disc
    x = jnp.ones((2, 3))
    layers = params["params"]
    logit = float(np.sum(np.square(layers["logit"]["kernel"])))
    every = sum(float(np.sum(np.square(layer["kernel"]))) for layer in layers.values())
    assert sorted(layers) == ["Dense_0", "Dense_1", "logit"] and every > logit > 0
    base, parts = amp.discriminator_loss(params, disc.apply, (x, x), (x, x), 0.0)
    assert float(parts["disc_logit_norm"]) == pytest.approx(logit, rel=1e-5)
    regularised, _ = amp.discriminator_loss(params, disc.apply, (x, x), (x, x), 0.0, 0.05, 1e-4)
    assert float(regularised - base) == pytest.approx(0.05 * logit + 1e-4 * every, rel=1e-4)

    # their gradient: 2 * (0.05 + 1e-4) W on the output layer, 2e-4 W elsewhere, 0 on biases
    def penalty(p):
        logit_norm, weight_norm = amp.kernel_norms(p)
        return 0.05 * logit_norm + 1e-4 * weight_norm

    grads = jax.grad(penalty)(params)["params"]
    kernel = lambda name: np.asarray(layers[name]["kernel"])  # noqa: E731
    np.testing.assert_allclose(grads["logit"]["kernel"], 2 * 0.0501 * kernel("logit"), rtol=1e-5)
    np.testing.assert_allclose(grads["Dense_0"]["kernel"], 2e-4 * kernel("Dense_0"), rtol=1e-5)
    np.testing.assert_array_equal(grads["Dense_0"]["bias"], 0.0)


def test_gradient_penalty_enters_with_its_full_weight(small_disc) -> None:
    disc, params = small_disc
    rng = np.random.default_rng(2)
    expert = tuple(jnp.asarray(rng.normal(size=(4, 3)), jnp.float32) for _ in range(2))
    policy = tuple(jnp.asarray(rng.normal(size=(4, 3)), jnp.float32) for _ in range(2))
    base, parts = amp.discriminator_loss(params, disc.apply, expert, policy, 0.0)
    weighted, _ = amp.discriminator_loss(params, disc.apply, expert, policy, 5.0)
    assert float(weighted - base) == pytest.approx(
        5.0 * float(parts["disc_grad_penalty"]), rel=1e-4
    )


def test_replay_buffer_keeps_a_long_history_once_full() -> None:
    buffer = amp.ReplayBuffer.create(1000, 1)
    rows = jnp.zeros((1000, 1))
    buffer = buffer.add(rows, rows, jax.random.key(0), keep=0.01)  # not full yet: all go in
    assert int(buffer.size) == 1000 and int(buffer.index) == 0
    new = jnp.ones((1000, 1))
    buffer = buffer.add(new, -new, jax.random.key(1), keep=0.01)
    kept = int(np.sum(np.asarray(buffer.current[:, 0]) == 1.0))
    assert 2 <= kept <= 25  # about 1 % of the new rows (binomial, 1000 x 0.01)
    assert int(buffer.index) == kept and int(buffer.size) == 1000
    # the kept rows took the oldest slots, in order, and stay paired
    np.testing.assert_array_equal(np.asarray(buffer.current[:kept, 0]), 1.0)
    np.testing.assert_array_equal(np.asarray(buffer.following), -np.asarray(buffer.current))


def test_replay_buffer_takes_the_last_rows_of_a_big_batch() -> None:
    buffer = amp.ReplayBuffer.create(4, 1)
    buffer = buffer.add(jnp.arange(10.0)[:, None], jnp.arange(10.0)[:, None])
    assert sorted(np.asarray(buffer.current[:, 0]).tolist()) == [6.0, 7.0, 8.0, 9.0]
    assert int(buffer.size) == 4


def test_replay_buffer_overwrites_the_oldest() -> None:
    buffer = amp.ReplayBuffer.create(5, 1)
    buffer = buffer.add(jnp.arange(3.0)[:, None], -jnp.arange(3.0)[:, None])
    assert int(buffer.size) == 3 and int(buffer.index) == 3
    buffer = buffer.add(jnp.arange(3.0, 7.0)[:, None], -jnp.arange(3.0, 7.0)[:, None])
    assert int(buffer.size) == 5 and int(buffer.index) == 2
    np.testing.assert_array_equal(np.asarray(buffer.current[:, 0]), [5, 6, 2, 3, 4])
    current, following = buffer.sample(jax.random.key(0), 100)
    np.testing.assert_array_equal(np.asarray(current), -np.asarray(following))
    assert set(np.asarray(current[:, 0]).tolist()) <= {2.0, 3.0, 4.0, 5.0, 6.0}


def test_prior_samples_follow_the_probabilities() -> None:
    prior = amp.PriorData.create(
        np.array([[0.0], [1.0]]), np.array([[10.0], [11.0]]), np.array([0.1, 0.9])
    )
    current, following = prior.sample(jax.random.key(0), 20000)
    assert float(jnp.mean(current)) == pytest.approx(0.9, abs=0.01)
    np.testing.assert_array_equal(np.asarray(following), np.asarray(current) + 10.0)


def test_simulator_features_equal_the_dataset_features(env, robot) -> None:
    """chi from an MJX state equals motionkit.dataset.amp_features of the same frames (the
    thrust as a share of T_max above the ideal jet's idle, 0 N, and the 2 % deadband)."""
    import mujoco

    from motionkit.dataset import amp_features
    from motionkit.dataset.synthetic import synthetic_trajectory
    from motionkit.robot.geometry import quat_rotate_inverse
    from motionkit.train.env.mjx import mjx

    clip = synthetic_trajectory(robot, 0.5, 10.0, thrust=80.0, turn_rate=0.7, seed=3)
    expected = amp_features(clip, robot)
    thrust = expected[:, env.layout.slice("thrust")]  # above 0 N idle and a 5 N deadband
    expected[:, env.layout.slice("thrust")] = np.maximum(thrust - 5.0, 0.0) / 250.0
    model = env.mj_model
    data = mujoco.MjData(model)
    for t in range(clip.frames):
        data.qpos[:3] = clip.base_position[t]
        data.qpos[3:7] = clip.base_orientation[t]
        data.qpos[7:] = clip.joint_positions[t]
        data.qvel[:3] = clip.base_linear_velocity[t]
        data.qvel[3:6] = quat_rotate_inverse(
            clip.base_orientation[t : t + 1], clip.base_angular_velocity[t : t + 1]
        )[0]
        data.qvel[6:] = clip.joint_velocities[t]
        mujoco.mj_kinematics(model, data)
        chi = env.features(mjx.put_data(model, data), jnp.asarray(clip.thrust[t]))
        np.testing.assert_allclose(np.asarray(chi), expected[t], atol=2e-5)
