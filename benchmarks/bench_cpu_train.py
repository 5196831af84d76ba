"""Training throughput on this CPU: the MuJoCo C backend against MJX-JAX, side by side.

    python benchmarks/bench_cpu_train.py [--iterations 8] [--mjx-iterations 2] [--envs 512]

Rows, each the CPU walking recipe (`train/walk_cpu.toml`, a synthetic walking prior so that the
discriminator and its replay run too):
- MuJoCo C (`impl = "mujoco"`), the recipe as it is;
- MJX-JAX (`impl = "jax"`), the same recipe;
- MuJoCo C with the GPU walking recipe's networks ([1024, 512] actor, critic, discriminator).
For each: env-steps/s of the rollout alone and of whole iterations (rollout + update), after
WARM_UP iterations that compile. The MuJoCo rows add where an iteration's time goes (the
rollout's phases as `PhaseClock` measures them, the rest of the rollout, and the update), and
the first line gives the ceiling of the physics alone: `Batch.step` of the same environments,
standing, no policy.
"""

from __future__ import annotations

import argparse
import time
from dataclasses import replace
from pathlib import Path
from tempfile import TemporaryDirectory

import jax
import jax.numpy as jnp
import numpy as np

from motionkit import recipes
from motionkit.robot import ironcub
from motionkit.train.config import PriorConfig, TrainConfig

GPU_NETWORKS = (1024, 512)
WARM_UP = 3  # iterations before the timed ones


def recipe(envs: int, prior: Path) -> TrainConfig:
    config = TrainConfig.from_toml(recipes.ROOT / "train" / "walk_cpu.toml")
    steps = envs * config.ppo.rollout_steps
    ppo = replace(config.ppo, num_envs=envs, minibatch_size=steps // config.ppo.minibatches)
    return replace(config, ppo=ppo, priors={"walk": PriorConfig((str(prior),))})


def with_impl(config: TrainConfig, impl: str) -> TrainConfig:
    return replace(config, env=replace(config.env, impl=impl))


def with_networks(config: TrainConfig, hidden: tuple[int, ...]) -> TrainConfig:
    ppo = replace(config.ppo, actor_hidden=hidden, critic_hidden=hidden)
    return replace(config, ppo=ppo, amp=replace(config.amp, hidden=hidden))


def synthetic_prior(folder: Path) -> Path:
    from motionkit.dataset import write
    from motionkit.dataset.synthetic import synthetic_trajectory

    robot = ironcub()
    return write(folder / "walk.mcap", synthetic_trajectory(robot, 4.0, 60.0, seed=1), robot)


def physics_ceiling(config: TrainConfig, repeats: int = 20) -> float:
    """Control steps/s of `Batch.step` alone for the recipe's environments, standing."""
    from motionkit.train.env import Env
    from motionkit.train.env.mujoco import BatchPhysics

    env = Env(ironcub(), with_impl(config, "mujoco").env, config.reward)
    physics = BatchPhysics(env, config.ppo.num_envs)
    physics.reset(jax.random.split(jax.random.key(0), config.ppo.num_envs))
    joints = np.asarray(env.joint_targets(env.rest_action[: env.num_joints]))
    ctrl = np.tile(np.concatenate([joints, np.zeros(env.num_jets)]), (config.ppo.num_envs, 1))
    physics.step(ctrl)
    tick = time.perf_counter()
    for _ in range(repeats):
        physics.step(ctrl)
    return repeats * config.ppo.num_envs / (time.perf_counter() - tick)


def measure(config: TrainConfig, iterations: int) -> dict[str, float]:
    """Env-steps/s of the rollout and of whole iterations, and (MuJoCo) the phases' shares."""
    from motionkit.train.learner import Trainer
    from motionkit.train.priors import load_priors
    from motionkit.train.runner import make_env

    robot = ironcub()
    prior, _ = load_priors(config.priors, robot, config.env.control_hz)
    trainer = Trainer(config, make_env(config, robot, prior))
    learner, carry = trainer.init(0)
    for _ in range(WARM_UP):  # compiles (the update twice, the resets per batch size)
        learner, carry, _ = trainer.iteration(learner, carry)
    clock = getattr(trainer, "clock", None)
    if clock is not None:
        clock.read()
    state, buffer, key = carry.env, carry.buffer, carry.key
    rollout = update = 0.0
    for _ in range(iterations):
        key, k_rollout, k_update = jax.random.split(key, 3)
        tick = time.perf_counter()
        state, batch = trainer.rollout(learner, state, k_rollout, jnp.array(1.0))
        jax.block_until_ready(batch)
        middle = time.perf_counter()
        learner, buffer, metrics = trainer.update(learner, buffer, batch, trainer.prior, k_update)
        jax.block_until_ready(metrics)
        rollout, update = rollout + middle - tick, update + time.perf_counter() - middle
    samples = iterations * config.ppo.num_envs * config.ppo.rollout_steps
    row = {"rollout": samples / rollout, "iteration": samples / (rollout + update)}
    total = rollout + update
    if clock is not None:
        phases = clock.read()
        phases["other"] = rollout - sum(phases.values())  # the draws, the stacking of the record
        row |= {f"share {k}": v / total for k, v in phases.items()}
    return row | {"share update": update / total}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--iterations", type=int, default=8, help="timed iterations per row")
    parser.add_argument("--mjx-iterations", type=int, default=2, help="... of the MJX row")
    parser.add_argument("--envs", type=int, default=512)
    args = parser.parse_args()
    with TemporaryDirectory() as scratch:
        config = recipe(args.envs, synthetic_prior(Path(scratch)))
        print(f"walk_cpu recipe, {args.envs} envs x {config.ppo.rollout_steps} steps")
        print(
            f"physics alone (Batch.step, standing): {physics_ceiling(config):,.0f} control steps/s"
        )
        rows = [
            ("MuJoCo C, walk_cpu [256, 256]", with_impl(config, "mujoco"), args.iterations),
            ("MJX-JAX, walk_cpu [256, 256]", with_impl(config, "jax"), args.mjx_iterations),
            (
                "MuJoCo C, GPU networks [1024, 512]",
                with_networks(with_impl(config, "mujoco"), GPU_NETWORKS),
                args.iterations,
            ),
        ]
        results = {name: measure(row_config, n) for name, row_config, n in rows}
    print("| backend and networks | rollout env-steps/s | training env-steps/s | time shares |")
    print("|---|---|---|---|")
    for name, row in results.items():
        shares = ", ".join(
            f"{k[6:]} {100 * v:.0f} %" for k, v in row.items() if k.startswith("share")
        )
        print(f"| {name} | {row['rollout']:,.0f} | {row['iteration']:,.0f} | {shares} |")
    mujoco_row, mjx_row = results[rows[0][0]], results[rows[1][0]]
    print(f"MuJoCo C / MJX-JAX, training: {mujoco_row['iteration'] / mjx_row['iteration']:.1f}x")


if __name__ == "__main__":
    main()
