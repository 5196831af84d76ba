"""The AMP trainer on MJX: environment steps per second during training, against a smaller
batch in the same run, and (optionally) the time to a policy that walks and flies between
waypoints on flat ground.

    python benchmarks/bench_train.py                      # CPU: batch 64 vs 8, 3 iterations
    python benchmarks/bench_train.py --device gpu         # GPU: 4,096 environments vs 256
    python benchmarks/bench_train.py --device gpu --time-to-policy --priors walk,flight

Targets (one H100): at least 200,000 env-steps/s during training at 4,096
environments; flat-ground walk-and-fly in at most 30 minutes. "Walks and flies" is measured by
the periodic evaluation: at least 2 waypoints per episode, at least 10 % of the time airborne
and 10 % on the ground, fewer than 0.5 falls per episode.
"""

from __future__ import annotations

import argparse
import tempfile
import time
from dataclasses import replace
from pathlib import Path

import jax
import jax.numpy as jnp

from motionkit import recipes
from motionkit.robot import ironcub
from motionkit.train.config import TrainConfig
from motionkit.train.learner import Trainer
from motionkit.train.runner import make_env

RECIPE = recipes.find("train", "paper_gpu")
TARGET_STEPS, TARGET_MINUTES = 200_000, 30.0


def verdict(ok: bool) -> str:
    return "PASS" if ok else "FAIL"


def sized(config: TrainConfig, batch: int) -> TrainConfig:
    """The recipe at `batch` environments (minibatches scaled to keep their number)."""
    ppo = config.ppo
    total = batch * ppo.rollout_steps
    minibatch = max(1, total // max(1, ppo.minibatches))
    while total % minibatch:
        minibatch -= 1
    amp = replace(config.amp, buffer_size=max(config.amp.buffer_size // 4096 * batch, total))
    return replace(config, ppo=replace(ppo, num_envs=batch, minibatch_size=minibatch), amp=amp)


def training_rate(config: TrainConfig, iterations: int) -> tuple[float, float, float]:
    """(env-steps/s of whole iterations, env-steps/s of the rollout alone, compile seconds)."""
    robot = ironcub()
    env = make_env(config, robot)
    trainer = Trainer(config, env)
    learner, carry = trainer.init(0)
    start = time.perf_counter()
    learner, carry, metrics = trainer.iteration(learner, carry)
    jax.block_until_ready(metrics)
    compile_s = time.perf_counter() - start
    steps = config.ppo.num_envs * config.ppo.rollout_steps
    start = time.perf_counter()
    for _ in range(iterations):
        learner, carry, metrics = trainer.iteration(learner, carry)
    jax.block_until_ready(metrics)
    whole = steps * iterations / (time.perf_counter() - start)
    start = time.perf_counter()
    state = carry.env
    for _ in range(iterations):
        state, batch = trainer.rollout(learner, state, carry.key, jnp.array(1.0))
    jax.block_until_ready(batch.obs)
    rollout = steps * iterations / (time.perf_counter() - start)
    return whole, rollout, compile_s


def time_to_policy(config: TrainConfig, minutes: float, out: Path) -> None:
    from motionkit.train.runner import train

    def walks_and_flies(e: dict[str, float]) -> bool:
        return (
            e["eval_waypoints_per_episode"] >= 2.0
            and 0.1 <= e["eval_airborne_share"] <= 0.9
            and e["eval_falls_per_episode"] < 0.5
        )

    # evaluations span a whole episode, so that "waypoints per episode" can reach 2
    chunks = -(-config.env.max_steps // config.ppo.rollout_steps)
    run = replace(
        config.run, max_minutes=minutes, eval_every=150, eval_rollouts=chunks, iterations=100_000
    )
    start = time.perf_counter()
    summary = train(replace(config, run=run), out, ironcub(), stop=walks_and_flies)
    seconds = time.perf_counter() - start
    met = bool(summary["eval"]) and walks_and_flies(summary["eval"])
    print(
        f"time to a walking-and-flying policy: {seconds / 60:.1f} min, {summary['iterations']} "
        f"iterations; criterion met: {met}; <= {TARGET_MINUTES:g} min: "
        f"{verdict(met and seconds <= 60 * TARGET_MINUTES)}"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--device", choices=("cpu", "gpu"), default=jax.default_backend())
    parser.add_argument("--batch", type=int, help="environments (gpu 4096, cpu 64)")
    parser.add_argument("--baseline-batch", type=int, help="smaller batch (gpu 256, cpu 8)")
    parser.add_argument("--iterations", type=int, default=3, help="timed iterations")
    parser.add_argument("--config", type=Path, default=RECIPE)
    parser.add_argument("--time-to-policy", action="store_true", help="train until walk-and-fly")
    parser.add_argument("--priors", default="walk,flight", help="for --time-to-policy")
    parser.add_argument("--minutes", type=float, default=TARGET_MINUTES)
    parser.add_argument("--out", type=Path, help="keep the time-to-policy run here (metrics CSV)")
    args = parser.parse_args()
    gpu = args.device == "gpu"
    if gpu and jax.default_backend() != "gpu":
        parser.error(f"--device gpu, but jax runs on {jax.default_backend()}")
    batch = args.batch or (4096 if gpu else 64)
    baseline = args.baseline_batch or (256 if gpu else 8)
    config = TrainConfig.from_toml(args.config)
    print(f"{args.config.name}; jax {jax.__version__} on {jax.devices()[0].device_kind}")
    rates = {}
    for label, size in (("batch", batch), ("baseline", baseline)):  # the target figure first
        whole, rollout, compile_s = training_rate(sized(config, size), args.iterations)
        rates[label] = whole
        print(
            f"  {label:<8} {size:>6} envs: training {whole:>10,.0f} env-steps/s, rollout alone "
            f"{rollout:>10,.0f} env-steps/s (first iteration incl. compile {compile_s:.0f} s)",
            flush=True,
        )
    speedup = rates["batch"] / rates["baseline"]
    print(f"  training throughput x{speedup:.1f} from {baseline} to {batch} environments")
    if gpu and batch == 4096:
        print(
            f"  target >= {TARGET_STEPS:,} env-steps/s at 4,096 envs: "
            f"{verdict(rates['batch'] >= TARGET_STEPS)}"
        )
    if args.time_to_policy:
        names = [n for n in args.priors.split(",") if n and n != "none"]
        config = config.select_priors(names)
        if args.out:
            time_to_policy(config, args.minutes, args.out)
        else:
            with tempfile.TemporaryDirectory() as folder:
                time_to_policy(config, args.minutes, Path(folder) / "run")


if __name__ == "__main__":
    main()
