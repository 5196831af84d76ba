"""Adversarial motion priors: the AMP features of an MJX state, the discriminator and its loss,
the replay buffer of policy transitions and the dataset (prior) transitions.

The features are those of `motionkit.dataset.amp_features`, in its `FeatureLayout`, so that
pairs from MCAP priors and from the simulator are comparable.
"""

from __future__ import annotations

from collections.abc import Sequence

import flax.linen as nn
import jax
import jax.numpy as jnp
import numpy as np
from flax import struct

from motionkit.dataset.amp import FeatureLayout
from motionkit.train.spatial import quat_to_matrix, remove_heading


def amp_features(
    layout: FeatureLayout,
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
    parts = {
        "base_orientation": remove_heading(quat, forward),
        "base_linear_velocity": quat_to_matrix(quat).T @ linear_world,
        "base_angular_velocity": angular_base,
        "joint_position": joint_positions,
        "joint_velocity": joint_velocities,
        "end_effectors": effectors_base.ravel(),
        "thrust": thrust,
    }
    return layout.join(parts, jnp)


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


def kernel_norms(params: dict) -> tuple[jax.Array, jax.Array]:
    """sum |W|^2 of the output layer's weights, and of every layer's weights (no biases)."""
    layers = params["params"]
    every = sum(jnp.sum(layer["kernel"] ** 2) for layer in layers.values())
    return jnp.sum(layers["logit"]["kernel"] ** 2), every


def discriminator_loss(
    params: dict,
    apply: callable,  # type: ignore[valid-type]
    expert: tuple[jax.Array, jax.Array],
    policy: tuple[jax.Array, jax.Array],
    gp_weight: float,
    logit_reg: float = 0.0,
    weight_decay: float = 0.0,
) -> tuple[jax.Array, dict[str, jax.Array]]:
    """BCE + gp_weight * gradient penalty at the prior samples + logit_reg * |W_out|^2 +
    weight_decay * sum |W|^2. Inputs are normalised features; returns the loss and its parts."""
    expert_logits = apply(params, *expert)
    policy_logits = apply(params, *policy)
    bce = bce_loss(expert_logits, policy_logits)
    penalty = gradient_penalty(apply, params, *expert)
    logit_norm, weight_norm = kernel_norms(params)
    loss = bce + gp_weight * penalty + logit_reg * logit_norm + weight_decay * weight_norm
    metrics = {
        "disc_loss": bce,
        "disc_grad_penalty": penalty,
        "disc_logit_norm": logit_norm,
        "disc_expert_accuracy": jnp.mean(expert_logits > 0),
        "disc_policy_accuracy": jnp.mean(policy_logits < 0),
    }
    return loss, metrics


@struct.dataclass
class ReplayBuffer:
    """A ring buffer of policy transitions (chi_t, chi_t+1). Once full, each new transition
    goes in with probability `keep` (replacing the oldest), so that it holds a long history
    of the policy's motion (the AMP reference keeps 1 % of new transitions)."""

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

    def add(
        self,
        current: jax.Array,
        following: jax.Array,
        key: jax.Array | None = None,
        keep: float = 1.0,
    ) -> ReplayBuffer:
        """Insert a batch (n, D), overwriting the oldest; into a full buffer only the rows
        kept with probability `keep` (every row when `key` is None)."""
        n = current.shape[0]
        take = jnp.ones(n, bool)
        if key is not None and keep < 1.0:
            sampled = jax.random.uniform(key, (n,)) < keep
            take = jnp.where(self.size >= self.capacity, sampled, take)
        order = jnp.cumsum(take) - 1
        # rows not taken get an out-of-range slot, which scatter drops
        slots = jnp.where(take, (self.index + order) % self.capacity, self.capacity)
        if n > self.capacity:  # only the last `capacity` rows fit
            slots = jnp.where(order >= order[-1] + 1 - self.capacity, slots, self.capacity)
        added = jnp.minimum(take.sum(), self.capacity)
        return ReplayBuffer(
            self.current.at[slots].set(current, mode="drop"),
            self.following.at[slots].set(following, mode="drop"),
            (self.index + take.sum()) % self.capacity,
            jnp.minimum(self.size + added, self.capacity),
        )

    def sample(self, key: jax.Array, count: int) -> tuple[jax.Array, jax.Array]:
        index = jax.random.randint(key, (count,), 0, jnp.maximum(self.size, 1))
        return self.current[index], self.following[index]


@struct.dataclass
class PriorStates:
    """The simulator state of every prior frame that starts a transition, for resets from the
    priors (reference state initialisation); row i belongs to transition i of `PriorData`."""

    qpos: jax.Array  # (N, 7 + J): base position, orientation (w, x, y, z), joints
    qvel: jax.Array  # (N, 6 + J): base linear velocity (world), angular (base frame), joints
    thrust: jax.Array  # (N, jets) N
    airborne: jax.Array  # (N,) both soles above the ground


@struct.dataclass
class PriorData:
    """Dataset transitions (features), the cumulative probability of drawing each, and the
    states they start from (None where unknown)."""

    current: jax.Array
    following: jax.Array
    cumulative: jax.Array
    states: PriorStates | None = None

    @classmethod
    def create(
        cls,
        current: np.ndarray,
        following: np.ndarray,
        probability: np.ndarray,
        states: PriorStates | None = None,
    ) -> PriorData:
        cumulative = np.cumsum(np.asarray(probability, dtype=np.float64))
        return cls(
            jnp.asarray(current, jnp.float32),
            jnp.asarray(following, jnp.float32),
            jnp.asarray(cumulative / cumulative[-1], jnp.float32),
            None if states is None else jax.tree.map(jnp.asarray, states),
        )

    def sample_index(self, key: jax.Array, shape: tuple[int, ...]) -> jax.Array:
        u = jax.random.uniform(key, shape)
        return jnp.minimum(jnp.searchsorted(self.cumulative, u), self.current.shape[0] - 1)

    def sample(self, key: jax.Array, count: int) -> tuple[jax.Array, jax.Array]:
        index = self.sample_index(key, (count,))
        return self.current[index], self.following[index]
