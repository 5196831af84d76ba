"""PPO pieces as small pure functions: the actor-critic, GAE, the clipped losses and the
adaptive learning rate that keeps the policy's KL step near a target."""

from __future__ import annotations

from collections.abc import Sequence

import flax.linen as nn
import jax
import jax.numpy as jnp

LOG_2PI = jnp.log(2 * jnp.pi)


class ActorCritic(nn.Module):
    """A Gaussian policy (MLP mean, state-independent std, learned or fixed) and a value MLP
    (ELU). The mean starts near `action_bias` (the environment's rest action): the mean layer's
    weights start at std `mean_init_scale`. `init_std`: one std for every action, or one each."""

    actions: int
    actor_hidden: Sequence[int]
    critic_hidden: Sequence[int]
    init_std: float | Sequence[float] = 1.0
    learn_std: bool = True
    action_bias: Sequence[float] | None = None
    mean_init_scale: float = 0.01  # std of the mean layer's initial weights

    @nn.compact
    def __call__(self, obs: jax.Array) -> tuple[jax.Array, jax.Array, jax.Array]:
        x = obs
        for width in self.actor_hidden:
            x = nn.elu(nn.Dense(width)(x))
        bias = (
            jnp.zeros(self.actions) if self.action_bias is None else jnp.asarray(self.action_bias)
        )
        mean = nn.Dense(
            self.actions,
            kernel_init=nn.initializers.normal(self.mean_init_scale),
            bias_init=lambda *_: bias,
        )(x)
        initial = jnp.log(jnp.broadcast_to(jnp.asarray(self.init_std, jnp.float32), self.actions))
        if self.learn_std:
            log_std = self.param("log_std", lambda *_: initial)
        else:
            log_std = initial
        v = obs
        for width in self.critic_hidden:
            v = nn.elu(nn.Dense(width)(v))
        value = nn.Dense(1)(v)[..., 0]
        return mean, jnp.broadcast_to(log_std, mean.shape), value


class Actor(nn.Module):
    """The actor of `ActorCritic` alone: its parameters (`actor_params`) give the same mean.
    A policy that acts (`motionkit.train.play`) needs nothing else."""

    actions: int
    hidden: Sequence[int]

    @nn.compact
    def __call__(self, obs: jax.Array) -> jax.Array:
        x = obs
        for width in self.hidden:
            x = nn.elu(nn.Dense(width)(x))
        return nn.Dense(self.actions)(x)


def actor_params(params: dict, hidden: Sequence[int]) -> dict:
    """The actor's part of `ActorCritic` parameters ({"params": ...}): its hidden layers and
    the mean layer (the first len(hidden) + 1 Dense layers, made first), without the critic
    and the action std."""
    layers = params["params"]
    return {"params": {f"Dense_{k}": layers[f"Dense_{k}"] for k in range(len(hidden) + 1)}}


def log_prob(mean: jax.Array, log_std: jax.Array, action: jax.Array) -> jax.Array:
    z = (action - mean) / jnp.exp(log_std)
    return jnp.sum(-0.5 * z**2 - log_std - 0.5 * LOG_2PI, axis=-1)


def entropy(log_std: jax.Array) -> jax.Array:
    return jnp.sum(log_std + 0.5 * (1.0 + LOG_2PI), axis=-1)


def gaussian_kl(
    mean_old: jax.Array, log_std_old: jax.Array, mean: jax.Array, log_std: jax.Array
) -> jax.Array:
    """KL(old || new) of diagonal Gaussians, summed over the action dimensions."""
    var_old, var = jnp.exp(2 * log_std_old), jnp.exp(2 * log_std)
    return jnp.sum(
        log_std - log_std_old + (var_old + (mean_old - mean) ** 2) / (2 * var) - 0.5, axis=-1
    )


def gae(
    rewards: jax.Array,
    values: jax.Array,
    dones: jax.Array,
    last_value: jax.Array,
    gamma: float,
    lam: float,
) -> tuple[jax.Array, jax.Array]:
    """Advantages and returns over time-major (T, ...) arrays. `dones[t]` = the episode ended
    at step t (the next value belongs to a new episode; time-limit bootstrapping is folded into
    the rewards by the caller); `last_value` is V of the state after the last step."""
    next_values = jnp.concatenate([values[1:], last_value[None]], axis=0)

    def backward(carry: jax.Array, xs: tuple[jax.Array, ...]) -> tuple[jax.Array, jax.Array]:
        reward, value, next_value, done = xs
        keep = 1.0 - done
        delta = reward + gamma * next_value * keep - value
        advantage = delta + gamma * lam * keep * carry
        return advantage, advantage

    _, advantages = jax.lax.scan(
        backward,
        jnp.zeros_like(last_value),
        (rewards, values, next_values, dones.astype(rewards.dtype)),
        reverse=True,
    )
    return advantages, advantages + values


def bounds_loss(mean: jax.Array, bound: float = 1.0) -> jax.Array:
    """Mean over samples of sum_j (max(mean_j - bound, 0)^2 + min(mean_j + bound, 0)^2): the
    penalty on action means outside [-bound, bound]."""
    high = jnp.maximum(mean - bound, 0.0) ** 2
    low = jnp.minimum(mean + bound, 0.0) ** 2
    return jnp.sum(high + low, axis=-1).mean()


def ppo_loss(
    mean: jax.Array,
    log_std: jax.Array,
    value: jax.Array,
    batch: dict[str, jax.Array],
    clip: float,
    value_coef: float,
    entropy_coef: float,
    value_clip: float = 0.0,
    bounds_coef: float = 0.0,
) -> tuple[jax.Array, dict[str, jax.Array]]:
    """Clipped surrogate + value_coef * value loss - entropy_coef * entropy + bounds_coef *
    bounds loss; the value step is clipped to +-value_clip around the old value when
    value_clip > 0; the advantages are normalised over the minibatch."""
    advantages = batch["advantages"]
    advantages = (advantages - advantages.mean()) / (advantages.std() + 1e-8)
    ratio = jnp.exp(log_prob(mean, log_std, batch["actions"]) - batch["log_probs"])
    surrogate = -jnp.minimum(
        ratio * advantages, jnp.clip(ratio, 1.0 - clip, 1.0 + clip) * advantages
    ).mean()
    value_loss = (value - batch["returns"]) ** 2
    if value_clip > 0:
        step = jnp.clip(value - batch["values"], -value_clip, value_clip)
        value_loss = jnp.maximum(value_loss, (batch["values"] + step - batch["returns"]) ** 2)
    value_loss = value_loss.mean()
    ent = entropy(log_std).mean()
    bounds = bounds_loss(mean)
    loss = surrogate + value_coef * value_loss - entropy_coef * ent + bounds_coef * bounds
    parts = {"surrogate": surrogate, "value_loss": value_loss, "entropy": ent}
    return loss, parts | {"bounds_loss": bounds}


def mirror_loss(
    mean_of_mirrored: jax.Array, mirrored_mean: jax.Array, log_std: jax.Array
) -> jax.Array:
    """The mean over rows and actions of ((mu(mirror(s)) - mirror(mu(s))) / std)^2, given
    mu(mirror(s)) and mirror(mu(s)): zero for a policy that acts as its own mirror image."""
    return jnp.mean(((mean_of_mirrored - mirrored_mean) / jnp.exp(log_std)) ** 2)


def adapt_learning_rate(
    lr: jax.Array, kl: jax.Array, target: float, low: float = 1e-5, high: float = 1e-2
) -> jax.Array:
    """Divide by 1.5 when the KL exceeds twice the target, multiply by 1.5 below half of it."""
    lr = jnp.where(kl > 2.0 * target, lr / 1.5, lr)
    lr = jnp.where((kl < 0.5 * target) & (kl > 0.0), lr * 1.5, lr)
    return jnp.clip(lr, low, high)
