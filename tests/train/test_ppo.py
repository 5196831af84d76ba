"""GAE, the PPO loss, the Gaussian KL and the adaptive learning rate against hand values."""

import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from motionkit.train import ppo


def test_gae_against_hand_computed_values() -> None:
    rewards = jnp.array([[1.0], [2.0], [3.0]])
    values = jnp.array([[0.5], [1.0], [1.5]])
    dones = jnp.array([[False], [True], [False]])  # the episode ends at step 1
    advantages, returns = ppo.gae(rewards, values, dones, jnp.array([2.0]), 0.9, 0.8)
    # t=2: 3 + 0.9 * 2.0 - 1.5 = 3.3
    # t=1: ends, so 2 - 1.0 = 1.0 (no bootstrap, no carry)
    # t=0: delta 1 + 0.9 * 1.0 - 0.5 = 1.4; A = 1.4 + 0.9 * 0.8 * 1.0 = 2.12
    np.testing.assert_allclose(np.asarray(advantages[:, 0]), [2.12, 1.0, 3.3], rtol=1e-6)
    np.testing.assert_allclose(np.asarray(returns[:, 0]), [2.62, 2.0, 4.8], rtol=1e-6)


def test_gae_with_lambda_one_is_the_discounted_return_minus_value() -> None:
    rng = np.random.default_rng(0)
    rewards, values = rng.normal(size=(5, 2)), rng.normal(size=(5, 2))
    last = rng.normal(size=2)
    advantages, _ = ppo.gae(
        jnp.asarray(rewards), jnp.asarray(values), jnp.zeros((5, 2), bool), jnp.asarray(last),
        0.95, 1.0,
    )  # fmt: skip
    discounted = last * 0.95**5 + sum(rewards[t] * 0.95**t for t in range(5))
    assert np.asarray(advantages[0]) == pytest.approx(discounted - values[0], rel=1e-5)


def test_log_prob_entropy_and_kl_of_a_1d_gaussian() -> None:
    mean, log_std = jnp.array([[0.5]]), jnp.array([[math.log(2.0)]])
    value = ppo.log_prob(mean, log_std, jnp.array([[1.5]]))
    expected = -0.5 * (1.0 / 2.0) ** 2 - math.log(2.0) - 0.5 * math.log(2 * math.pi)
    assert float(value[0]) == pytest.approx(expected, rel=1e-6)
    assert float(ppo.entropy(log_std)[0]) == pytest.approx(
        0.5 * math.log(2 * math.pi * math.e * 4.0), rel=1e-6
    )
    # KL(N(0.5, 2^2) || N(0, 1)) = log(1/2) + (4 + 0.25) / 2 - 1/2
    kl = ppo.gaussian_kl(mean, log_std, jnp.zeros((1, 1)), jnp.zeros((1, 1)))
    assert float(kl[0]) == pytest.approx(math.log(0.5) + 4.25 / 2 - 0.5, rel=1e-6)


def test_ppo_loss_clips_the_ratio() -> None:
    # two samples with advantages +1 and -1 (normalised: +-1/std = +-1), log ratio log 2
    batch = {
        "actions": jnp.zeros((2, 1)),
        "log_probs": ppo.log_prob(jnp.zeros((2, 1)), jnp.zeros((2, 1)), jnp.zeros((2, 1)))
        - math.log(2.0),
        "advantages": jnp.array([1.0, -1.0]),
        "values": jnp.array([0.0, 0.0]),
        "returns": jnp.array([1.0, 1.0]),
    }
    args = (jnp.zeros((2, 1)), jnp.zeros((2, 1)), jnp.array([0.5, 0.1]), batch, 0.2, 5.0, 0.0)
    loss, parts = ppo.ppo_loss(*args, value_clip=0.2)
    # surrogate: -mean(min(2 * 1, 1.2 * 1), min(2 * -1, 1.2 * -1)) = -(1.2 - 2) / 2 = 0.4
    assert float(parts["surrogate"]) == pytest.approx(0.4, rel=1e-4)
    # value: clipped to +-0.2 around the old 0 -> max((0.5-1)^2, (0.2-1)^2), max(0.81, 0.81)
    assert float(parts["value_loss"]) == pytest.approx((0.64 + 0.81) / 2, rel=1e-5)
    assert float(loss) == pytest.approx(0.4 + 5.0 * 0.725, rel=1e-4)
    # without value clipping (the default): ((0.5-1)^2 + (0.1-1)^2) / 2
    loss, parts = ppo.ppo_loss(*args)
    assert float(parts["value_loss"]) == pytest.approx((0.25 + 0.81) / 2, rel=1e-5)


def test_bounds_loss_against_hand_values() -> None:
    mean = jnp.array([[1.5, 0.0, -1.2], [0.9, -3.0, 1.0]])
    # row 0: 0.5^2 + 0 + 0.2^2 = 0.29; row 1: 0 + 2^2 + 0 = 4; mean 2.145
    assert float(ppo.bounds_loss(mean)) == pytest.approx(2.145, rel=1e-6)
    batch = {
        "actions": jnp.zeros((2, 3)),
        "log_probs": jnp.zeros(2),
        "advantages": jnp.array([1.0, -1.0]),
        "values": jnp.zeros(2),
        "returns": jnp.zeros(2),
    }
    plain, _ = ppo.ppo_loss(mean, jnp.zeros((2, 3)), jnp.zeros(2), batch, 0.2, 5.0, 0.0)
    bounded, parts = ppo.ppo_loss(
        mean, jnp.zeros((2, 3)), jnp.zeros(2), batch, 0.2, 5.0, 0.0, bounds_coef=10.0
    )
    assert float(parts["bounds_loss"]) == pytest.approx(2.145, rel=1e-6)
    assert float(bounded - plain) == pytest.approx(21.45, rel=1e-5)
    # its gradient: 2 (m - 1) above, 2 (m + 1) below, / 2 rows
    grad = np.asarray(jax.grad(ppo.bounds_loss)(mean))
    np.testing.assert_allclose(grad, [[0.5, 0.0, -0.2], [0.0, -2.0, 0.0]], rtol=1e-6)


def test_adaptive_learning_rate() -> None:
    lr = jnp.array(1e-3)
    assert float(ppo.adapt_learning_rate(lr, jnp.array(0.05), 0.008)) == pytest.approx(1e-3 / 1.5)
    assert float(ppo.adapt_learning_rate(lr, jnp.array(0.001), 0.008)) == pytest.approx(1.5e-3)
    assert float(ppo.adapt_learning_rate(lr, jnp.array(0.008), 0.008)) == pytest.approx(1e-3)
    capped = ppo.adapt_learning_rate(jnp.array(1e-2), jnp.array(1e-4), 0.008)
    assert float(capped) == pytest.approx(1e-2)  # the upper bound


def test_actor_critic_shapes() -> None:
    net = ppo.ActorCritic(3, (8,), (8,), init_std=0.5)
    params = net.init(jax.random.key(0), jnp.zeros((1, 5)))
    mean, log_std, value = net.apply(params, jnp.ones((4, 5)))
    assert mean.shape == log_std.shape == (4, 3) and value.shape == (4,)
    np.testing.assert_allclose(np.exp(np.asarray(log_std)), 0.5, rtol=1e-6)
    assert "log_std" in params["params"]


def test_fixed_std_and_the_initial_mean() -> None:
    net = ppo.ActorCritic(3, (8,), (8,), init_std=math.exp(-2.9), learn_std=False,
                          action_bias=(0.2, -0.5, -1.0))  # fmt: skip
    params = net.init(jax.random.key(0), jnp.zeros((1, 5)))
    assert "log_std" not in params["params"]  # not learned
    mean, log_std, _ = net.apply(params, jnp.zeros((2, 5)))
    np.testing.assert_allclose(np.asarray(log_std), -2.9, rtol=1e-6)
    # zero input: the mean is the output bias, the rest action
    np.testing.assert_allclose(np.asarray(mean), [[0.2, -0.5, -1.0]] * 2, atol=1e-6)


@pytest.mark.parametrize("learn_std", [False, True])
def test_one_std_per_action(learn_std: bool) -> None:
    stds = (0.07, 0.07, 0.2)
    net = ppo.ActorCritic(3, (8,), (8,), init_std=stds, learn_std=learn_std)
    params = net.init(jax.random.key(0), jnp.zeros((1, 5)))
    _, log_std, _ = net.apply(params, jnp.zeros((2, 5)))
    np.testing.assert_allclose(np.exp(np.asarray(log_std)), [stds] * 2, rtol=1e-6)
    assert ("log_std" in params["params"]) == learn_std


@pytest.mark.parametrize("learn_std", [False, True])
def test_the_actor_alone_gives_the_actor_critics_mean(learn_std: bool) -> None:
    net = ppo.ActorCritic(5, (16, 8), (12,), 0.5, learn_std, (0.1, 0.2, 0.3, 0.4, 0.5))
    params = net.init(jax.random.key(0), jnp.zeros((1, 7)))
    actor = ppo.actor_params(params, (16, 8))
    assert set(actor["params"]) == {"Dense_0", "Dense_1", "Dense_2"}  # no critic, no log_std
    obs = jax.random.normal(jax.random.key(1), (4, 7))
    mean, _, _ = net.apply(params, obs)
    np.testing.assert_array_equal(ppo.Actor(5, (16, 8)).apply(actor, obs), mean)
