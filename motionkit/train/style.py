"""Adversarial motion priors as one part of the learner: the discriminator on pairs
(chi_t, chi_t+1) of AMP features, its optimiser, the replay buffer of policy transitions it
trains against, the feature normaliser and the style reward it gives the policy.

    style = AdversarialStyle(config.amp, steps=epochs * minibatches)
    disc, disc_opt = style.init(key, chi_size)
    amp_norm, reward, accuracy = style.reward(disc, amp_norm, prior, chi, chi_next, key)
    disc, disc_opt, buffer, parts = style.train(disc, disc_opt, amp_norm, pairs, buffer, prior, key)
"""

from __future__ import annotations

from typing import Any

import jax
import jax.numpy as jnp
import optax

from motionkit.train.amp import Discriminator, PriorData, ReplayBuffer, discriminator_loss
from motionkit.train.config import AmpConfig
from motionkit.train.env.rewards import style_reward
from motionkit.train.normalize import RunningNorm


class AdversarialStyle:
    """`steps`: discriminator steps per iteration when `config.updates` is 0."""

    def __init__(self, config: AmpConfig, steps: int) -> None:
        self.config = config
        self.steps = config.updates or steps
        self.net = Discriminator(config.hidden)
        self.tx = optax.adam(config.learning_rate)

    def init(self, key: jax.Array, chi_size: int) -> tuple[Any, Any]:
        """The discriminator's parameters and optimiser state."""
        chi = jnp.zeros((1, chi_size))
        params = self.net.init(key, chi, chi)
        return params, self.tx.init(params)

    def reward(
        self,
        disc: Any,
        amp_norm: RunningNorm,
        prior: PriorData,
        chi: jax.Array,
        chi_next: jax.Array,
        key: jax.Array,
    ) -> tuple[RunningNorm, jax.Array, jax.Array]:
        """The normaliser updated with as many prior rows as policy rows, the style reward of
        every transition (chi, chi_next) and the discriminator's accuracy on them."""
        size = self.config.batch_size
        k_expert, k_policy = jax.random.split(key)
        policy_rows = chi_next.reshape(-1, amp_norm.mean.size)
        rows = jax.random.randint(k_policy, (size,), 0, policy_rows.shape[0])
        expert_rows, _ = prior.sample(k_expert, size)
        amp_norm = amp_norm.update(jnp.concatenate([policy_rows[rows], expert_rows]))
        logits = self.net.apply(disc, amp_norm(chi), amp_norm(chi_next))
        return amp_norm, style_reward(logits, self.config.style_scale), jnp.mean(logits < 0)

    def train(
        self,
        disc: Any,
        opt: Any,
        amp_norm: RunningNorm,
        pairs: tuple[jax.Array, jax.Array],
        buffer: ReplayBuffer,
        prior: PriorData,
        key: jax.Array,
    ) -> tuple[Any, Any, ReplayBuffer, dict[str, jax.Array]]:
        """The rollout's policy pairs into the replay buffer, then `steps` discriminator
        steps: prior pairs (label 1) against policy pairs (label 0), half of them from this
        rollout and half from the buffer. Returns each step's loss parts."""
        amp = self.config
        k_replay, k_steps = jax.random.split(key)
        buffer = buffer.add(*pairs, k_replay, amp.replay_keep)
        half = amp.batch_size // 2

        def one(carry: tuple, k: jax.Array) -> tuple[tuple, dict[str, jax.Array]]:
            disc, opt = carry
            k_expert, k_rollout, k_buffer = jax.random.split(k, 3)
            rows = jax.random.randint(k_rollout, (half,), 0, pairs[0].shape[0])
            replay = buffer.sample(k_buffer, half)
            policy = tuple(
                jnp.concatenate([p[rows], r]) for p, r in zip(pairs, replay, strict=True)
            )
            grads, parts = jax.grad(discriminator_loss, has_aux=True)(
                disc,
                self.net.apply,
                tuple(map(amp_norm, prior.sample(k_expert, amp.batch_size))),
                tuple(map(amp_norm, policy)),
                amp.gradient_penalty,
                amp.logit_reg,
                amp.weight_decay,
            )
            updates, opt = self.tx.update(grads, opt, disc)
            return (optax.apply_updates(disc, updates), opt), parts

        (disc, opt), parts = jax.lax.scan(one, (disc, opt), jax.random.split(k_steps, self.steps))
        return disc, opt, buffer, parts
