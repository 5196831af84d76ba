"""The MuJoCo C backend: the environments' physics in one `mujoco.batch.Batch`, stepped on all
the CPU's cores between the jitted task functions of `Env` (`control`, `advance`, `start`).
The model is the environment's own (`Env.mj_model`): on a course it holds the course's
heightfield, the grid the task samples its heights from, as MJX's model does.

The Batch holds the physics state (float64, with the solver's warm start); an `EnvState`'s
`data` is a float32 `Kinematics` copy of what the task reads, tagged with the index of the
batch that holds it (`Kinematics.batch`). Physics results do not depend on the thread count.
As in MJX, the link and site poses read after a step are those of the last substep's start
(MuJoCo's derived fields), the positions and velocities those after it.

Only the environments whose episode ended are reset: their rows of the Batch go back to the
standing keyframe, take the new pose and get their kinematics; the task's `start` runs for
those rows alone, padded to a power of two (at least MIN_ROWS) so that few shapes are ever
compiled.
"""

from __future__ import annotations

import os
from typing import Any

import jax
import jax.numpy as jnp
import mujoco
import numpy as np
from flax import struct
from mujoco import batch as mj_batch

from motionkit.train.env.levels import Tile
from motionkit.train.env.task import Env, EnvState, ResetPose

READ = ("qpos", "qvel", "xpos", "xmat", "site_xpos")  # the fields the task reads
MIN_ROWS = 16  # restarts are padded to at least this many rows (at most the batch)


@struct.dataclass
class Kinematics:
    """The physics state the task reads, as MJX names it, and the batch that holds it."""

    qpos: jax.Array
    qvel: jax.Array
    xpos: jax.Array  # (bodies, 3)
    xmat: jax.Array  # (bodies, 3, 3)
    site_xpos: jax.Array  # (sites, 3)
    batch: jax.Array  # int32: index of the `BatchPhysics` holding this environment


def cpu_threads() -> int:
    """The cores this process may run on."""
    return len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()


class BatchPhysics:
    """`num_envs` copies of `env`'s model in a persistent `mujoco.batch.Batch` on `threads`
    threads (0: every core this process may use); `index` tags the states it produces."""

    def __init__(self, env: Env, num_envs: int, threads: int = 0, index: int = 0) -> None:
        self.env, self.num_envs, self.index = env, num_envs, index
        self.threads = threads or cpu_threads()
        model = env.mj_model
        self.batch = mj_batch.Batch(model, num_envs, nthread=self.threads, persistent=True)
        self.fields = {name: self.batch.bind(name) for name in READ}
        self.ctrl = self.batch.bind("ctrl")
        self.keyframe = model.key("stand").id
        self.substeps = env.config.substeps
        self.xmat_shape = (model.nbody, 3, 3)
        self._start = jax.jit(_start_rows, static_argnums=0)
        self._poses = jax.jit(jax.vmap(env.reset_pose))
        self._start_all = jax.jit(jax.vmap(env.start))

    def kinematics(self, rows: np.ndarray | None = None) -> Kinematics:
        """The task's view of the physics now (float32), of `rows` (default: all)."""
        pick = slice(None) if rows is None else rows
        arrays = {name: np.asarray(value[pick], np.float32) for name, value in self.fields.items()}
        count = len(arrays["qpos"])
        arrays["xmat"] = arrays["xmat"].reshape(count, *self.xmat_shape)
        return Kinematics(**arrays, batch=np.full(count, self.index, np.int32))

    def step(self, ctrl: jax.Array) -> Kinematics:
        """One control step of every environment at `ctrl` (N, nu)."""
        self.ctrl[:] = np.asarray(ctrl)
        self.batch.step(None, nstep=self.substeps)
        return self.kinematics()

    def place(self, rows: np.ndarray, qpos: np.ndarray, qvel: np.ndarray) -> Kinematics:
        """Rows of the batch (sorted, unique) restarted at the standing keyframe's other
        values with these positions and velocities; their kinematics."""
        self.batch.reset(rows, self.keyframe, stage=mujoco.mjtStage.mjSTAGE_NONE)
        self.fields["qpos"][rows] = qpos
        self.fields["qvel"][rows] = qvel
        self.batch.forward(rows, stage=mujoco.mjtStage.mjSTAGE_POS)
        return self.kinematics(rows)

    def reset(
        self,
        keys: jax.Array,
        air_share: jax.Array | float | None = None,
        prior_share: jax.Array | float | None = None,
        tiles: Tile | None = None,
    ) -> EnvState:
        """A new episode in every environment (the keys: one each), as `Env.reset`; on a
        course, on `tiles` (one each; None: the training's first tiles)."""
        count = keys.shape[0]
        if count != self.num_envs:
            raise ValueError(f"{count} keys for a batch of {self.num_envs} environments")
        air = jnp.full(count, self.env.config.air_probability if air_share is None else air_share)
        share = self.env.default_prior_share if prior_share is None else prior_share
        prior = jnp.full(count, share)
        pose = self._poses(keys, air, prior, tiles)
        rows = np.arange(count)
        data = self.place(rows, np.asarray(pose.qpos), np.asarray(pose.qvel))
        return self._start_all(pose, data)

    def restart(self, state: EnvState, pose: ResetPose, done: np.ndarray) -> EnvState:
        """`state` with the environments where `done` restarted at their rows of `pose`."""
        ended = np.flatnonzero(done)
        if not ended.size:
            return state
        count = ended.size
        rows = np.full(
            min(max(MIN_ROWS, 1 << int(count - 1).bit_length()), self.num_envs), ended[-1]
        )
        rows[:count] = ended
        picked = _pick(pose, rows)
        self.place(ended, np.asarray(picked.qpos)[:count], np.asarray(picked.qvel)[:count])
        return self._start(self.env, state, picked, self.kinematics(rows), rows)


@jax.jit
def _pick(tree: Any, rows: jax.Array) -> Any:
    return jax.tree.map(lambda x: x[rows], tree)


def _start_rows(
    env: Env, state: EnvState, pose: ResetPose, data: Kinematics, rows: jax.Array
) -> EnvState:
    fresh = jax.vmap(env.start)(pose, data)
    return jax.tree.map(lambda old, new: old.at[rows].set(new), state, fresh)


def stepper(env: Env, physics: list[BatchPhysics]) -> Any:
    """`step(state, action) -> (state, info)` of a batch on the MuJoCo backend, `Env.step`'s
    counterpart (auto-reset included), for tests and tools that step without a policy."""
    control = jax.jit(jax.vmap(env.control))
    advance = jax.jit(jax.vmap(env.advance))

    def step(state: EnvState, action: jax.Array) -> tuple[EnvState, Any]:
        sims = physics[int(state.data.batch[0])]
        ctrl, jet, thrust = control(state, action)
        stepped, info, pose = advance(state, sims.step(ctrl), jet, thrust)
        return sims.restart(stepped, pose, np.asarray(info.done)), info

    return step
