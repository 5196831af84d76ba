"""Running mean and variance of observations (merged batch by batch), as a pytree."""

from __future__ import annotations

import jax
import jax.numpy as jnp
from flax import struct


@struct.dataclass
class RunningNorm:
    mean: jax.Array
    var: jax.Array
    count: jax.Array

    @classmethod
    def create(cls, size: int) -> RunningNorm:
        return cls(jnp.zeros(size), jnp.ones(size), jnp.array(1e-4))

    def update(self, batch: jax.Array) -> RunningNorm:
        """Merge the statistics of `batch` (..., size) (parallel variance formula)."""
        flat = batch.reshape(-1, batch.shape[-1])
        n = flat.shape[0]
        mean, var = flat.mean(axis=0), flat.var(axis=0)
        total = self.count + n
        delta = mean - self.mean
        new_mean = self.mean + delta * n / total
        m2 = self.var * self.count + var * n + delta**2 * self.count * n / total
        return RunningNorm(new_mean, m2 / total, total)

    def __call__(self, x: jax.Array, clip: float = 10.0) -> jax.Array:
        return jnp.clip((x - self.mean) / jnp.sqrt(self.var + 1e-6), -clip, clip)
