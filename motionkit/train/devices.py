"""Training on several devices of one host: a 1-D mesh over the first N local devices, the
environment batch split along it (each device steps num_envs / N environments), everything
learned (networks, optimisers, normalisers, replay buffer) replicated on every device.

    mesh = make_mesh(config.run.devices, config.ppo.num_envs)
    jax.device_put(state, batch_sharding(mesh))        # leading axis: the environments

`devices` is a count, or 0 / "all" for every local device. The PPO and discriminator losses
are means over the global batch, so under `jit` their gradients are the average of the
devices' parts; the rollout runs per device (`shard_map`).
"""

from __future__ import annotations

import jax
from jax.sharding import Mesh, NamedSharding, PartitionSpec

from motionkit.core.errors import TrainError

AXIS = "envs"  # the mesh axis the environment batch is split along
FORCE_HOST = "XLA_FLAGS=--xla_force_host_platform_device_count=N"


def resolve_devices(requested: int | str, available: int, num_envs: int) -> int:
    """How many devices `requested` means (0 or "all": every one of `available`); TrainError
    when there are fewer than that or they do not split `num_envs` evenly."""
    count = available if requested in (0, "all") else requested
    if not isinstance(count, int) or isinstance(count, bool) or count < 0:
        raise TrainError(f"devices {requested!r}: expected a count >= 1, 0 or 'all'")
    if count > available:
        raise TrainError(
            f"devices {count}: this host has {available} local JAX device(s) "
            f"(on a CPU, {FORCE_HOST} set before JAX starts makes N)"
        )
    if num_envs % count:
        raise TrainError(
            f"devices {count}: num_envs ({num_envs}) must be a multiple of the device count"
        )
    return count


def make_mesh(requested: int | str, num_envs: int) -> Mesh:
    """The 1-D mesh over the first `resolve_devices(...)` local devices."""
    local = jax.local_devices()
    count = resolve_devices(requested, len(local), num_envs)
    return Mesh(local[:count], (AXIS,))


def replicated(mesh: Mesh) -> NamedSharding:
    return NamedSharding(mesh, PartitionSpec())


def batch_sharding(mesh: Mesh, axis: int = 0) -> NamedSharding:
    """Arrays split along `axis` (the environments) over the mesh."""
    return NamedSharding(mesh, PartitionSpec(*([None] * axis), AXIS))


def resolve_impl(impl: str) -> str:
    """The physics backend `impl` means here: "auto" is MJX on JAX where JAX sees a GPU and
    MuJoCo C (`mujoco.batch`) on a CPU; any other name is itself."""
    if impl != "auto":
        return impl
    return "mujoco" if jax.default_backend() == "cpu" else "jax"
