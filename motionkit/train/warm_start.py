"""A fresh run that starts from a trained policy's actor (`motionkit train --init-from POLICY`):
the actor's layers and the observation normaliser come from the policy; the critic, the action
std, the discriminator and the optimisers start afresh, as in any new run.

A flat-ground policy sees one height (the base above the ground); a terrain run's observation
holds the 7 x 9 height map instead (terrain heights relative to the base: on flat ground each
cell is minus that height). Such a policy is widened to the map: the centre cell (under the
base) takes the old input's weights with their sign turned and its normaliser statistics
negated, the other cells start with zero weights and the same statistics. On flat ground the
widened policy then acts exactly as the flat one; on a terrain it learns the other cells.
"""

from __future__ import annotations

from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

from motionkit.core.errors import TrainError
from motionkit.train.env import HEIGHT_MAP
from motionkit.train.normalize import RunningNorm
from motionkit.train.policy import Policy

MAP_CELLS = HEIGHT_MAP[0] * HEIGHT_MAP[1]
CENTRE = (HEIGHT_MAP[0] // 2) * HEIGHT_MAP[1] + HEIGHT_MAP[1] // 2  # the cell under the base


def widen_to_height_map(
    kernel: np.ndarray, norm: RunningNorm, heights_at: int
) -> tuple[np.ndarray, RunningNorm]:
    """The first layer's kernel (obs, width) and normaliser of a flat-ground policy, whose one
    height input is at `heights_at`, for an observation with the height map there instead."""
    kernel = np.asarray(kernel)
    mean, var = np.asarray(norm.mean), np.asarray(norm.var)
    cells = np.zeros((MAP_CELLS, kernel.shape[1]), kernel.dtype)
    cells[CENTRE] = -kernel[heights_at]

    def spliced(array: np.ndarray, inserted: np.ndarray) -> np.ndarray:
        return np.concatenate([array[:heights_at], inserted, array[heights_at + 1 :]])

    widened = RunningNorm(
        jnp.asarray(spliced(mean, np.full(MAP_CELLS, -mean[heights_at]))),
        jnp.asarray(spliced(var, np.full(MAP_CELLS, var[heights_at]))),
        norm.count,
    )
    return spliced(kernel, cells), widened


def init_from_policy(learner: Any, policy: Policy, obs_size: int, heights_at: int) -> Any:
    """`learner` (a fresh one, on the host) with the actor and observation normaliser of
    `policy`; TrainError where the policy does not fit (other hidden layers or actions, or an
    observation that differs by more than the height map)."""
    params = learner.policy["params"]
    layers = len(policy.hidden)
    actor = {k: dict(v) for k, v in policy.actor["params"].items()}
    norm = RunningNorm(
        jnp.asarray(policy.obs_norm.mean), jnp.asarray(policy.obs_norm.var), policy.obs_norm.count
    )
    if policy.obs_size == obs_size - MAP_CELLS + 1:
        kernel, norm = widen_to_height_map(actor["Dense_0"]["kernel"], norm, heights_at)
        actor["Dense_0"]["kernel"] = kernel
    for k in range(layers + 1):
        name = f"Dense_{k}"
        theirs, ours = actor[name]["kernel"], params[name]["kernel"]
        if np.shape(theirs) != np.shape(ours):
            raise TrainError(
                f"--init-from {policy.source}: its actor's layer {k} is "
                f"{'x'.join(map(str, np.shape(theirs)))}, this config's "
                f"{'x'.join(map(str, np.shape(ours)))} (the observation, the hidden layers "
                "[ppo] actor_hidden and the robot's actions must agree, or differ only by the "
                "terrain's height map)"
            )
    as_float = lambda a: jnp.asarray(a, jnp.float32)  # noqa: E731
    merged = dict(params) | {f"Dense_{k}": jax.tree.map(as_float, actor[f"Dense_{k}"])
                             for k in range(layers + 1)}  # fmt: skip
    return learner.replace(policy={**learner.policy, "params": merged}, obs_norm=norm)
