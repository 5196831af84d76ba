"""Before and after the AMP machinery: the earlier training recipe against `train/walk_gpu.toml`
scaled down to a CPU, in one run with the same walking prior, seed and iterations.

    python benchmarks/bench_amp.py [--walk DIR] [--iterations 30] [--envs 64] [--json OUT]

Prints, over iterations 1-10, 11-20 and 21-30: falls per episode, episode length, the
discriminator's accuracy on this rollout's policy transitions, and the style reward (also as
-log(1 - D), the same quantity without the recipe's scale). The earlier recipe is expressed in
today's keys (resets standing only, 0.5 rad around the standing posture, a learned std starting
at 1, value clipping at 0.2, an adaptive learning rate, a discriminator with logit
regularisation 1e-4, no weight decay, gradient penalty 2.5, learning rate 1e-4, a replay buffer
of about 10 iterations, 20 s episodes, waypoints without deadline, v_d 0.8 m/s); two things of
the earlier trainer have no key and are today's in both runs: the feature normaliser sees equal
numbers of prior and policy rows, and half of the discriminator's policy samples come from the
rollout. Without --walk the CMU clips of the offline sample are retargeted into a temporary
folder first.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from motionkit import recipes

if TYPE_CHECKING:
    from motionkit.robot import Robot
    from motionkit.train.config import TrainConfig

ROOT = Path(__file__).resolve().parents[1]
SHARED_MOCAP = recipes.sample_mocap()
WINDOWS = ((1, 10), (11, 20), (21, 30))
FIGURES = {
    "falls per episode": "falls_per_episode",
    "episode length [s]": "episode_seconds",
    "discriminator accuracy, policy": "disc_policy_accuracy_rollout",
    "style reward": "style_reward",
    "-log(1 - D)": "style_unscaled",
}

EARLIER = {
    "env": {
        "episode_seconds": 20.0,
        "action_mapping": "stand",
        "action_scale": 0.5,
        "reset_from_prior": 0.0,
        "waypoint_timeout": False,
        "air_height": (1.2, 2.0),
    },
    "reward": {"v_desired": 0.8},
    "ppo": {
        "rollout_steps": 24,
        "epochs": 5,
        "lr_schedule": "adaptive",
        "value_clip": 0.2,
        "bounds_coef": 0.0,
        "init_std": 1.0,
        "learn_std": True,
        "actor_hidden": (512, 256, 128),
        "critic_hidden": (512, 256, 128),
    },
    "amp": {
        "learning_rate": 1e-4,
        "gradient_penalty": 2.5,
        "logit_reg": 1e-4,
        "weight_decay": 0.0,
        "style_scale": 1.0,
        "replay_keep": 1.0,
    },
}


def scaled(config: TrainConfig, envs: int, buffer_iterations: int) -> TrainConfig:
    """The config at `envs` environments: two minibatches per epoch, 512 discriminator
    samples, a replay buffer holding `buffer_iterations` iterations before it keeps 1 %."""
    steps = envs * config.ppo.rollout_steps
    ppo = replace(config.ppo, num_envs=envs, minibatch_size=steps // 2)
    amp = replace(config.amp, batch_size=512, buffer_size=buffer_iterations * steps)
    return replace(config, ppo=ppo, amp=amp)


def earlier_recipe(base: TrainConfig) -> TrainConfig:
    tables = {name: replace(getattr(base, name), **values) for name, values in EARLIER.items()}
    return replace(base, **tables)


def walk_prior(folder: str | None, scratch: Path) -> Path:
    if folder:
        return Path(folder)
    if not SHARED_MOCAP.is_dir():
        sys.exit(f"no --walk folder and no {SHARED_MOCAP} to retarget: pass --walk DIR")
    out = scratch / "walk"
    subprocess.run(
        [sys.executable, "-m", "motionkit.cli", "retarget", str(SHARED_MOCAP), "--out", str(out)],
        check=True,
        stdout=subprocess.DEVNULL,
    )
    return out


def train_rows(config: TrainConfig, robot: Robot, iterations: int) -> list[dict[str, float]]:
    from motionkit.train.learner import Trainer
    from motionkit.train.priors import load_priors
    from motionkit.train.runner import make_env

    prior, _ = load_priors(config.priors, robot, config.env.control_hz)
    trainer = Trainer(config, make_env(config, robot, prior))
    learner, carry = trainer.init(config.run.seed)
    rows = []
    for i in range(iterations):
        tick = time.perf_counter()
        learner, carry, metrics = trainer.iteration(learner, carry)
        row = {k: float(v) for k, v in metrics.items()}
        row["style_unscaled"] = row["style_reward"] / config.amp.style_scale
        row["seconds"] = time.perf_counter() - tick
        rows.append(row)
        print(
            f"  iter {i + 1}: falls {row['falls']:.0f}, episode {row['episode_seconds']:.2f} s, "
            f"accuracy {row['disc_policy_accuracy_rollout']:.2f}, style {row['style_reward']:.3f}"
            f" ({row['seconds']:.1f} s)",
            flush=True,
        )
    return rows


def window_mean(rows: list[dict[str, float]], key: str, first: int, last: int) -> float:
    values = np.array([r[key] for r in rows[first - 1 : last]], dtype=float)
    return float(np.nanmean(values)) if np.isfinite(values).any() else float("nan")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--walk", help="folder of retargeted walking clips (MCAP)")
    parser.add_argument("--iterations", type=int, default=30)
    parser.add_argument("--envs", type=int, default=64)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--json", type=Path, help="also write the per-iteration figures here")
    args = parser.parse_args()

    import jax

    from motionkit.robot import ironcub
    from motionkit.train.config import PriorConfig, TrainConfig
    from motionkit.train.runtime import enable_compile_cache

    enable_compile_cache()
    robot = ironcub()
    with tempfile.TemporaryDirectory() as scratch:
        walk = walk_prior(args.walk, Path(scratch))
        recipe = TrainConfig.from_toml(recipes.find("train", "walk_gpu"))
        recipe = replace(
            recipe,
            priors={"walk": PriorConfig((str(walk),))},
            run=replace(recipe.run, seed=args.seed),
        )
        configs = {
            "earlier": scaled(earlier_recipe(recipe), args.envs, 10),
            "walk_gpu": scaled(recipe, args.envs, 10),
        }
        results = {}
        for name, config in configs.items():
            print(f"{name}: {args.envs} environments, {args.iterations} iterations", flush=True)
            results[name] = train_rows(config, robot, args.iterations)

    windows = [w for w in WINDOWS if w[0] <= args.iterations]
    head = "".join(f"{f'{a}-{min(b, args.iterations)}':>9}" for a, b in windows)
    print(
        f"\n{args.envs} environments, seed {args.seed}, jax {jax.__version__}, {jax.devices()[0]}"
    )
    print(f"{'figure':34}{'recipe':>10}{head}")
    for label, key in FIGURES.items():
        for name, rows in results.items():
            cells = "".join(
                f"{window_mean(rows, key, a, min(b, args.iterations)):9.3f}" for a, b in windows
            )
            print(f"{label:34}{name:>10}{cells}")
    for name, rows in results.items():
        falls = sum(r["falls"] for r in rows)
        ended = sum(r["episodes"] for r in rows)
        print(f"{name}: {falls:.0f} falls in {ended:.0f} ended episodes")
    if args.json:
        args.json.write_text(json.dumps(results, indent=1) + "\n")


if __name__ == "__main__":
    main()
