"""Adversarial motion priors: the AMP features of an MJX state, the discriminator and its loss,
the replay buffer of policy transitions and the dataset (prior) transitions.

The features are those of `motionkit.dataset.amp_features` (heading-free base orientation,
base-frame velocities, joints, end effectors relative to the base in the base frame, thrust),
so that pairs from MCAP priors and from the simulator are comparable.
"""

from __future__ import annotations

from collections.abc import Sequence

import flax.linen as nn
import jax
import jax.numpy as jnp
import numpy as np
from flax import struct

from motionkit.train.spatial import quat_to_matrix, remove_heading


def amp_features(
    quat: jax.Array,
    linear_world: jax.Array,
    angular_base: jax.Array,
    joint_positions: jax.Array,
    joint_velocities: jax.Array,
    effectors_base: jax.Array,
    thrust: jax.Array,
    forward: jax.Array,
) -> jax.Array:
    """chi of one state: quat (4,) of the base in the world, its linear velocity in the world,
    its angular velocity in the base frame (MuJoCo's free-joint convention), joints (J,), end
    effectors relative to the base in the base frame (E, 3), thrust (jets,) [N]."""
    rotation = quat_to_matrix(quat)
    return jnp.concatenate(
        [
            remove_heading(quat, forward),
            rotation.T @ linear_world,
            angular_base,
            joint_positions,
            joint_velocities,
            effectors_base.ravel(),
            thrust,
        ]
    )


class Discriminator(nn.Module):
    """D(chi_t, chi_t+1): an MLP on the normalised pair, one logit (> 0: looks like the prior)."""

    hidden: Sequence[int]

    @nn.compact
    def __call__(self, current: jax.Array, following: jax.Array) -> jax.Array:
        x = jnp.concatenate([current, following], axis=-1)
        for width in self.hidden:
            x = nn.relu(nn.Dense(width)(x))
        return nn.Dense(1, name="logit")(x)[..., 0]


def bce_loss(expert_logits: jax.Array, policy_logits: jax.Array) -> jax.Array:
    """Binary cross-entropy with label 1 for prior pairs and 0 for policy pairs."""
    expert = jnp.mean(jax.nn.softplus(-expert_logits))  # -log sigmoid(d)
    policy = jnp.mean(jax.nn.softplus(policy_logits))  # -log(1 - sigmoid(d))
    return 0.5 * (expert + policy)


def gradient_penalty(
    apply: callable,  # type: ignore[valid-type]
    params: dict,
    current: jax.Array,
    following: jax.Array,
) -> jax.Array:
    """mean over samples of |grad_(chi_t, chi_t+1) D|^2 at the (prior) samples."""

    def single(c: jax.Array, f: jax.Array) -> jax.Array:
        gc, gf = jax.grad(lambda c, f: apply(params, c, f), argnums=(0, 1))(c, f)
        return jnp.sum(gc**2) + jnp.sum(gf**2)

    return jnp.mean(jax.vmap(single)(current, following))


def discriminator_loss(
    params: dict,
    apply: callable,  # type: ignore[valid-type]
    expert: tuple[jax.Array, jax.Array],
    policy: tuple[jax.Array, jax.Array],
    gp_weight: float,
    weight_decay: float,
) -> tuple[jax.Array, dict[str, jax.Array]]:
    """BCE + gp_weight / 2 * gradient penalty at the prior samples + weight decay on the output
    layer. Inputs are normalised features; returns the loss and its parts."""
    expert_logits = apply(params, *expert)
    policy_logits = apply(params, *policy)
    bce = bce_loss(expert_logits, policy_logits)
    penalty = gradient_penalty(apply, params, *expert)
    decay = jnp.sum(params["params"]["logit"]["kernel"] ** 2)
    loss = bce + 0.5 * gp_weight * penalty + weight_decay * decay
    metrics = {
        "disc_loss": bce,
        "disc_grad_penalty": penalty,
        "disc_expert_accuracy": jnp.mean(expert_logits > 0),
        "disc_policy_accuracy": jnp.mean(policy_logits < 0),
    }
    return loss, metrics


@struct.dataclass
class ReplayBuffer:
    """A ring buffer of policy transitions (chi_t, chi_t+1)."""

    current: jax.Array  # (capacity, D)
    following: jax.Array
    index: jax.Array  # next slot
    size: jax.Array  # slots filled

    @classmethod
    def create(cls, capacity: int, dim: int) -> ReplayBuffer:
        zeros = jnp.zeros((capacity, dim))
        return cls(zeros, zeros, jnp.array(0), jnp.array(0))

    @property
    def capacity(self) -> int:
        return self.current.shape[0]

    def add(self, current: jax.Array, following: jax.Array) -> ReplayBuffer:
        """Insert a batch (n, D), n <= capacity, overwriting the oldest."""
        n = current.shape[0]
        slots = (self.index + jnp.arange(n)) % self.capacity
        return ReplayBuffer(
            self.current.at[slots].set(current),
            self.following.at[slots].set(following),
            (self.index + n) % self.capacity,
            jnp.minimum(self.size + n, self.capacity),
        )

    def sample(self, key: jax.Array, count: int) -> tuple[jax.Array, jax.Array]:
        index = jax.random.randint(key, (count,), 0, jnp.maximum(self.size, 1))
        return self.current[index], self.following[index]


@struct.dataclass
class PriorData:
    """Dataset transitions (raw features) and the cumulative probability of drawing each."""

    current: jax.Array
    following: jax.Array
    cumulative: jax.Array

    @classmethod
    def create(
        cls, current: np.ndarray, following: np.ndarray, probability: np.ndarray
    ) -> PriorData:
        cumulative = np.cumsum(np.asarray(probability, dtype=np.float64))
        return cls(
            jnp.asarray(current, jnp.float32),
            jnp.asarray(following, jnp.float32),
            jnp.asarray(cumulative / cumulative[-1], jnp.float32),
        )

    def sample(self, key: jax.Array, count: int) -> tuple[jax.Array, jax.Array]:
        u = jax.random.uniform(key, (count,))
        index = jnp.minimum(jnp.searchsorted(self.cumulative, u), self.current.shape[0] - 1)
        return self.current[index], self.following[index]
