"""The fixed action std of the walking recipe: `train/walk_gpu.toml` scaled down to a CPU and
trained at several stds side by side, one `motionkit train` process each, for the same
iterations and seed.

    python benchmarks/bench_action_std.py [--walk DIR] [--stds 0.01 0.05] [--envs 128]
        [--iterations 800] [--seed 0] [--out DIR]

Prints, over the first, middle and last third of the iterations: episode length and falls per
ended episode (resets as in training: 85 % in a walking frame), style and task reward, the
policy's KL step per minibatch and the discriminator's accuracy on the rollout; then the final
evaluation from standing without action noise (falls per episode, episode length, speed toward
the waypoint). The std sets PPO's trust region as well as the exploration: Adam moves the
action mean by about the same amount whatever the std, so the KL of one step grows as 1 / std^2.
Without --walk the CMU clips of the offline sample are retargeted into the output folder first.
"""

from __future__ import annotations

import argparse
import csv
import os
import subprocess
import sys
import tempfile
from dataclasses import replace
from pathlib import Path

import numpy as np
from bench_amp import scaled, walk_prior

from motionkit import recipes

TRAIN_FIGURES = {
    "episode length [s]": "episode_seconds",
    "falls per ended episode": "falls_per_episode",
    "style reward": "style_reward",
    "task reward": "task_reward",
    "KL per minibatch": "kl",
    "discriminator accuracy, policy": "disc_policy_accuracy_rollout",
}
EVAL_FIGURES = {
    "falls per episode": "eval_falls_per_episode",
    "episode length [s]": "eval_episode_seconds",
    "speed toward waypoint [m/s]": "eval_approach_speed",
    "single support share": "eval_single_support_share",
    "task reward": "eval_task_reward",
}


def recipe(walk: Path, std: float, envs: int, iterations: int, seed: int) -> str:
    """walk_gpu at `envs` environments and action std `std`, evaluated once at the end over a
    whole episode."""
    from motionkit.train.config import PriorConfig, TrainConfig

    config = scaled(TrainConfig.from_toml(recipes.find("train", "walk_gpu")), envs, 10)
    chunks = -(-config.env.max_steps // config.ppo.rollout_steps)
    run = replace(
        config.run,
        iterations=iterations,
        seed=seed,
        max_minutes=0.0,
        eval_every=0,
        eval_rollouts=chunks,
        checkpoint_every=iterations,
        log_every=max(iterations // 20, 1),
        tensorboard=False,
    )
    ppo = replace(config.ppo, init_std=std)
    return replace(config, ppo=ppo, run=run, priors={"walk": PriorConfig((str(walk),))}).to_toml()


def read_csv(path: Path) -> list[dict[str, float]]:
    with path.open() as f:
        return [
            {k: float(v) if v else float("nan") for k, v in row.items()}
            for row in csv.DictReader(f)
        ]


def third_means(rows: list[dict[str, float]], key: str) -> list[float]:
    values = np.array([r.get(key, float("nan")) for r in rows], dtype=float)
    parts = np.array_split(values, 3)
    return [float(np.nanmean(p)) if np.isfinite(p).any() else float("nan") for p in parts]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--walk", help="folder of retargeted walking clips (MCAP)")
    parser.add_argument("--stds", type=float, nargs="+", default=[0.01, 0.05])
    parser.add_argument("--envs", type=int, default=128)
    parser.add_argument("--iterations", type=int, default=800)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--out", type=Path, help="keep the runs here (default: a temporary folder)")
    args = parser.parse_args()
    if args.iterations < 3:
        sys.exit("--iterations must be at least 3 (the table has thirds)")

    with tempfile.TemporaryDirectory() as scratch:
        out = args.out or Path(scratch)
        out.mkdir(parents=True, exist_ok=True)
        walk = walk_prior(args.walk, out)
        runs = {}
        for k, std in enumerate(args.stds):
            folder = out / f"std_{std:g}"
            toml = out / f"std_{std:g}.toml"
            toml.write_text(recipe(walk, std, args.envs, args.iterations, args.seed))
            command = [sys.executable, "-m", "motionkit.cli", "train", "--config", str(toml)]
            log = (out / f"std_{std:g}.log").open("w")
            # one core each where there are enough: the runs do not slow each other down
            cpus = sorted(os.sched_getaffinity(0))
            pin = {cpus[k % len(cpus)]} if len(args.stds) <= len(cpus) else set(cpus)
            runs[std] = (
                folder,
                log,
                subprocess.Popen(
                    [*command, "--out", str(folder)],
                    stdout=log,
                    stderr=subprocess.STDOUT,
                    preexec_fn=lambda pin=pin: os.sched_setaffinity(0, pin),
                ),
            )
            print(f"std {std:g}: training in {folder} (log {log.name})", flush=True)
        failed = [std for std, (_, _, p) in runs.items() if p.wait() != 0]
        for _, log, _ in runs.values():
            log.close()
        if failed:
            sys.exit(f"training failed at std {failed}: see the logs in {out}")

        train = {std: read_csv(folder / "train.csv") for std, (folder, _, _) in runs.items()}
        final = {std: read_csv(folder / "eval.csv")[-1] for std, (folder, _, _) in runs.items()}

    print(f"\nwalk_gpu at {args.envs} environments, {args.iterations} iterations, seed {args.seed}")
    print(f"{'in training (thirds of the run)':34}{'std':>7}{'first':>9}{'middle':>9}{'last':>9}")
    for label, key in TRAIN_FIGURES.items():
        for std, rows in train.items():
            cells = "".join(f"{x:9.3f}" for x in third_means(rows, key))
            print(f"{label:34}{std:7g}{cells}")
    print(f"\n{'final evaluation (from standing)':34}{'std':>7}{'value':>9}")
    for label, key in EVAL_FIGURES.items():
        for std, row in final.items():
            print(f"{label:34}{std:7g}{row[key]:9.3f}")


if __name__ == "__main__":
    main()
