"""One training recipe within a wall-clock budget, for a rented GPU: train, keep the checkpoint,
and write every figure measured to OUT/gpu_run.json (strict JSON) and OUT/gpu_run.txt.

    benchmarks/gpu_runs.sh walk_fly_gpu 8 --priors-dir /data/priors
    python benchmarks/gpu_run.py walk_gpu 8 --out runs/gpu/walk
    python benchmarks/gpu_run.py walk_gpu 8 --out runs/gpu/walk \\
        --resume runs/gpu/walk/checkpoint.msgpack

The budget covers the whole call (imports, compilation, training, the final evaluation and the
reports); training gets [run] max_minutes = budget - margin - time already spent, where the
margin is 15 % of the budget and at least 0.5 min; the trainer evaluates the final policy
whether it stops at [run] iterations or at the time limit.
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import platform
import shutil
import socket
import subprocess
import sys
import time
from dataclasses import replace
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

from motionkit import recipes
from motionkit.core.errors import MotionkitError, TrainError
from motionkit.files.outputs import strict_json, write_text_atomic

ROOT = Path(__file__).resolve().parents[1]
CHECKPOINT = "checkpoint.msgpack"
MARGIN_SHARE, MARGIN_MIN, TRAIN_MIN = 0.15, 0.5, 0.2  # minutes
# train.csv columns whose first and last logged values go into gpu_run.txt
TRAIN_FIGURES = (
    "style_reward",
    "disc_policy_accuracy_rollout",
    "disc_expert_accuracy",
    "disc_policy_accuracy",
    "falls_per_episode",
    "episode_seconds",
    "approach_speed",
    "single_support_share",
    "contact_switches_per_second",
    "airborne_share",
    "thrust_usage",
    "waypoints_per_episode",
    "prior_reset_share",
)

EPILOG = """\
Outputs in --out (default runs/gpu/<recipe stem>): the trainer's config.toml, train.csv,
eval.csv, summary.json, checkpoint.msgpack, rollouts/ and tensorboard/, and
  checkpoint_slim.msgpack
                the checkpoint without the optimisers' moments (a third of the size: to
                carry to another machine or commit; a run resumed from it starts them afresh)
  gpu_run.json  recipe, budget, timestamps, device and versions, iterations, env-steps,
                throughput (mean env-steps/s after the first iteration of this call), the first
                iteration's seconds (compilation), train.csv and eval.csv as columns over time
                (empty cells as null), the final evaluation and the priors summary
  gpu_run.txt   a short summary of the same (also printed at the end)

Without --resume, an --out that holds a checkpoint is refused. With --resume CHECKPOINT (full
or slim) the file is copied to OUT/checkpoint.msgpack (unless it is that file) and training
continues up to [run] iterations; --jets-at-rest sets the policy's jet outputs at rest first
(a checkpoint of another jet action: walk_gpu's rate to fly_gpu's thrust set point). The small
overrides (--num-envs ...) are for smoke runs on a CPU. Errors in the inputs print one line
`error: ...` and exit with status 2. Walking, then flying, then both, as on the CPU:

  benchmarks/gpu_runs.sh walk_gpu 8 --priors-dir /data/priors
  benchmarks/gpu_runs.sh fly_gpu 8 --priors-dir /data/priors --jets-at-rest \\
      --resume runs/gpu/walk_gpu/checkpoint_slim.msgpack
  benchmarks/gpu_runs.sh walk_fly_gpu 8 --priors-dir /data/priors \\
      --resume runs/gpu/fly_gpu/checkpoint_slim.msgpack
  benchmarks/gpu_runs.sh walk_fly_gpu 3 --priors-dir /tmp/p --num-envs 8 \\
      --minibatch-size 64 --iterations 2 --eval-rollouts 2 --eval-every 0"""


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(
        prog="gpu_runs.sh",
        description="Run one training recipe within a wall-clock budget of MINUTES (compilation "
        "and the final evaluation included), keep its checkpoint, and write every figure it "
        "measured to OUT/gpu_run.json and a short summary to OUT/gpu_run.txt.",
        epilog=EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument(
        "recipe", help="a training recipe: a TOML file or a built-in name (walk_fly_gpu)"
    )
    parser.add_argument(
        "minutes",
        type=_positive_float,
        nargs="?",
        default=8.0,
        help="wall-clock budget of the whole call in minutes (default 8)",
    )
    parser.add_argument("--out", type=Path, help="run folder (default runs/gpu/<recipe stem>)")
    parser.add_argument(
        "--resume",
        type=Path,
        metavar="CHECKPOINT",
        help="continue from this checkpoint.msgpack (copied into --out)",
    )
    parser.add_argument(
        "--jets-at-rest",
        action="store_true",
        help="with --resume of another run's checkpoint: the policy's jet outputs start at "
        "rest (for a checkpoint trained with another jet action: fly_gpu from walk_gpu)",
    )
    parser.add_argument(
        "--priors-dir",
        type=Path,
        metavar="DIR",
        help="take each [priors.NAME] from DIR/NAME (a folder of MCAP clips) instead of the "
        "recipe's paths",
    )
    overrides = parser.add_argument_group("overrides (smoke runs)")
    overrides.add_argument("--num-envs", type=int, metavar="N", help="[ppo] num_envs")
    overrides.add_argument("--minibatch-size", type=int, metavar="N", help="[ppo] minibatch_size")
    overrides.add_argument("--iterations", type=int, metavar="N", help="[run] iterations")
    overrides.add_argument("--eval-rollouts", type=int, metavar="N", help="[run] eval_rollouts")
    overrides.add_argument(
        "--eval-every", type=int, metavar="N", help="[run] eval_every (0: only at the end)"
    )
    return parser.parse_args(argv)


def _positive_float(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected minutes, got {text!r}") from None
    if not (math.isfinite(value) and value > 0):
        raise argparse.ArgumentTypeError(f"minutes must be > 0, got {text!r}")
    return value


def train_minutes(budget: float, spent: float, recipe_limit: float = 0.0) -> float:
    """[run] max_minutes for a call of `budget` minutes of which `spent` are gone: the budget
    less a margin for the final evaluation (15 %, at least 0.5 min), at least 0.2 min, and
    never more than the recipe's own limit (0: none)."""
    minutes = max(budget - max(MARGIN_SHARE * budget, MARGIN_MIN) - spent, TRAIN_MIN)
    if recipe_limit > 0:
        minutes = min(minutes, recipe_limit)
    return round(minutes, 3)


def with_priors_dir(config: Any, folder: Path) -> Any:
    """`config` with [priors.NAME] paths = [DIR/NAME] for every prior of the recipe."""
    if not folder.is_dir():
        raise TrainError(f"--priors-dir {folder}: no such folder")
    priors = {}
    for name, prior in config.priors.items():
        path = folder / name
        if not path.is_dir():
            raise TrainError(
                f"--priors-dir {folder}: no folder {path} for [priors.{name}] (expected one "
                f"folder per prior: {', '.join(str(folder / n) for n in config.priors)})"
            )
        priors[name] = replace(prior, paths=(str(path.resolve()),))
    return replace(config, priors=priors)


def check_prior_paths(config: Any) -> None:
    """Fail before compiling anything when a prior's clips are not there."""
    for name, prior in config.priors.items():
        for path in prior.paths:
            if not Path(path).exists():
                raise TrainError(
                    f"[priors.{name}] {path}: no such file or folder (from {Path.cwd()}); "
                    "write the priors or pass --priors-dir DIR with DIR/NAME per prior"
                )


def with_overrides(config: Any, args: argparse.Namespace) -> Any:
    """`config` with the smoke-run overrides; the dataclasses check them (TrainError)."""
    ppo = {"num_envs": args.num_envs, "minibatch_size": args.minibatch_size}
    run = {
        "iterations": args.iterations,
        "eval_rollouts": args.eval_rollouts,
        "eval_every": args.eval_every,
    }
    ppo = {k: v for k, v in ppo.items() if v is not None}
    run = {k: v for k, v in run.items() if v is not None}
    return replace(config, ppo=replace(config.ppo, **ppo), run=replace(config.run, **run))


def prepare_out(out: Path, resume: Path | None, jets_at_rest: bool = False) -> None:
    """Refuse to train over a run, or to set the jets at rest in a run's own checkpoint; put
    the checkpoint to resume from in place."""
    from motionkit.train.checkpoint import place_checkpoint

    checkpoint = out / CHECKPOINT
    if resume is None:
        if jets_at_rest:
            raise TrainError("--jets-at-rest needs --resume CHECKPOINT (another run's)")
        if checkpoint.exists():
            raise TrainError(
                f"{out} holds a run already ({checkpoint}): continue it with --resume "
                f"{checkpoint}, or pass another --out"
            )
        return
    if place_checkpoint(out, resume, "--resume"):
        print(f"gpu_run: copied {resume} to {checkpoint}", flush=True)
    elif jets_at_rest:
        raise TrainError(
            f"--jets-at-rest: {resume} is the run's own checkpoint; its jets were set at rest "
            "when the run began (leave --jets-at-rest out)"
        )


def read_columns(path: Path) -> dict[str, list[Any]]:
    """A metrics CSV as {column: values over rows}; empty or non-finite cells are None."""
    if not path.is_file():
        return {}
    with path.open(newline="") as stream:
        rows = list(csv.reader(stream))
    if not rows:
        return {}
    header = rows[0]
    columns: dict[str, list[Any]] = {name: [] for name in header}
    for row in rows[1:]:
        for index, name in enumerate(header):
            cell = row[index] if index < len(row) else ""
            columns[name].append(_number(cell, integer=name == "iteration"))
    return columns


def _number(cell: str, integer: bool = False) -> Any:
    cell = cell.strip()
    if not cell:
        return None
    try:
        value = float(cell)
    except ValueError:
        return cell
    if not math.isfinite(value):
        return None
    return int(value) if integer and value.is_integer() else value


def row_count(path: Path) -> int:
    return len(next(iter(read_columns(path).values()), []))


def _finite(values: list[Any]) -> list[float]:
    return [v for v in values if isinstance(v, int | float) and math.isfinite(v)]


def throughput(train: dict[str, list[Any]], first_row: int) -> dict[str, Any]:
    """Env-steps/s (mean after the first iteration) and the first iteration's wall seconds of
    the rows this call added (rows from `first_row` on)."""
    rates = train.get("env_steps_per_second", [])[first_row:]
    walls = train.get("wall_seconds", [])[first_row:]
    after = _finite(rates[1:])
    return {
        "env_steps_per_second": sum(after) / len(after) if after else None,
        "first_iteration_seconds": walls[0] if walls else None,
        "iterations_this_call": len(rates),
    }


def nvidia_smi() -> str | None:
    command = shutil.which("nvidia-smi")
    if command is None:
        return None
    try:
        result = subprocess.run(
            [command, "--query-gpu=name,driver_version", "--format=csv,noheader"],
            capture_output=True,
            text=True,
            timeout=30,
            check=False,
        )
    except (OSError, subprocess.TimeoutExpired) as exc:
        return f"failed: {exc}"
    if result.returncode:
        return f"failed ({result.returncode}): {result.stderr.strip() or result.stdout.strip()}"
    return result.stdout.strip()


def device_info() -> dict[str, Any]:
    import flax
    import jax
    import jaxlib
    import mujoco

    devices = jax.devices()
    return {
        "platform": devices[0].platform,
        "device_kind": devices[0].device_kind,
        "device_count": len(devices),
        "jax": jax.__version__,
        "jaxlib": jaxlib.__version__,
        "mujoco": mujoco.__version__,
        "flax": flax.__version__,
        "python": platform.python_version(),
        "hostname": socket.gethostname(),
        "nvidia_smi": nvidia_smi(),
    }


def _utc() -> str:
    return datetime.now(UTC).isoformat(timespec="seconds")


def _fmt(value: Any) -> str:
    if value is None:
        return "n/a"
    if isinstance(value, float):
        return f"{value:.4g}"
    return str(value)


def first_last(values: list[Any]) -> tuple[Any, Any] | None:
    logged = [v for v in values if v is not None]
    return (logged[0], logged[-1]) if logged else None


def summary_text(report: dict[str, Any], out: Path) -> str:
    device = report.get("device", {})
    speed = report.get("throughput", {})
    lines = [
        f"gpu_run {report['status']}: {report['recipe']} -> {out}",
        f"device: {device.get('platform')} {device.get('device_kind')} "
        f"(jax {device.get('jax')}, mujoco {device.get('mujoco')}, host {device.get('hostname')})",
        f"budget: {report['budget_minutes']:g} min, training limit {report['train_minutes']:g} "
        f"min, wall {report['wall_seconds'] / 60:.2f} min",
        f"iterations: {_fmt(report.get('iterations'))} ({_fmt(speed.get('iterations_this_call'))} "
        f"this call, stopped by the time limit: {_fmt(report.get('stopped_by_time'))}), "
        f"env-steps {_fmt(report.get('env_steps'))}",
        f"throughput: {_fmt(speed.get('env_steps_per_second'))} env-steps/s after the first "
        f"iteration; first iteration {_fmt(speed.get('first_iteration_seconds'))} s",
        f"training {_fmt(report.get('train_seconds'))} s (compilation and evaluations included)",
    ]
    sizes = report.get("checkpoint_bytes")
    if sizes:
        lines.append(
            f"checkpoint: {sizes['full'] / 1e6:.1f} MB, slim {sizes['slim'] / 1e6:.1f} MB "
            "(checkpoint_slim.msgpack: without the optimisers' moments)"
        )
    if report.get("error"):
        lines.append(f"error: {report['error']}")
    evaluation = report.get("final_evaluation") or {}
    lines.append(f"final evaluation (iteration {_fmt(report.get('final_evaluation_iteration'))}):")
    lines += [f"  {name} = {_fmt(value)}" for name, value in evaluation.items()]
    columns = report.get("train_csv", {})
    trends = [(n, first_last(columns[n])) for n in TRAIN_FIGURES if n in columns]
    trends = [(n, fl) for n, fl in trends if fl is not None]
    if trends:
        lines.append("train.csv, first -> last logged:")
        lines += [f"  {n}: {_fmt(first)} -> {_fmt(last)}" for n, (first, last) in trends]
    return "\n".join(lines) + "\n"


def write_reports(report: dict[str, Any], out: Path) -> str:
    out.mkdir(parents=True, exist_ok=True)
    text = json.dumps(strict_json(report), indent=2, allow_nan=False) + "\n"
    write_text_atomic(out / "gpu_run.json", text)
    summary = summary_text(report, out)
    write_text_atomic(out / "gpu_run.txt", summary)
    return summary


def run(args: argparse.Namespace, clock: float, started: str) -> int:
    from motionkit.train.checkpoint import SLIM_NAME, write_slim
    from motionkit.train.config import TrainConfig

    recipe = recipes.find("train", args.recipe)
    config = TrainConfig.from_toml(recipe)
    if args.priors_dir is not None:
        config = with_priors_dir(config, args.priors_dir)
    check_prior_paths(config)
    config = with_overrides(config, args)
    out = args.out if args.out is not None else Path("runs/gpu") / recipe.stem
    prepare_out(out, args.resume, args.jets_at_rest)

    from motionkit.train.runtime import enable_compile_cache, require_train_extra

    require_train_extra()
    from motionkit.robot import ironcub
    from motionkit.train.runner import train

    enable_compile_cache()
    device = device_info()
    spent = (time.perf_counter() - clock) / 60
    limit = train_minutes(args.minutes, spent, config.run.max_minutes)
    config = replace(config, run=replace(config.run, max_minutes=limit))
    print(
        f"gpu_run: {recipe} into {out}, budget {args.minutes:g} min, training limit {limit:g} min "
        f"(recipe {config.run.iterations} iterations at most), {config.ppo.num_envs} envs, "
        f"priors {', '.join(f'{n}={list(p.paths)}' for n, p in config.priors.items()) or 'none'}"
        f"{', resume' if args.resume else ''}",
        flush=True,
    )
    print(
        f"gpu_run: device {device['platform']} {device['device_kind']} x{device['device_count']}, "
        f"jax {device['jax']}, nvidia-smi {device['nvidia_smi']}",
        flush=True,
    )
    rows_before = row_count(out / "train.csv")
    report: dict[str, Any] = {
        "status": "running",
        "recipe": str(args.recipe),
        "out": str(out),
        "budget_minutes": args.minutes,
        "train_minutes": limit,
        "started": started,
        "device": device,
        "resumed_from": str(args.resume) if args.resume else None,
        "jets_at_rest": args.jets_at_rest,
        "config": config.to_dict(),
    }
    summary: dict[str, Any] = {}
    robot = ironcub()
    try:
        summary = train(
            config,
            out,
            robot,
            resume=args.resume is not None,
            jets_at_rest=args.jets_at_rest,
            progress=print_flush,
        )
        slim = write_slim(out / CHECKPOINT, out / SLIM_NAME)
        report["checkpoint_bytes"] = {"full": (out / CHECKPOINT).stat().st_size, "slim": slim}
        report["final_evaluation"] = summary.get("eval") or {}
        report["final_evaluation_iteration"] = int(summary["iterations"])
        report["status"] = "ok"
    except BaseException as exc:
        report["status"] = "failed"
        report["error"] = f"{type(exc).__name__}: {exc}"
        _finish(report, summary, out, config, rows_before, clock)
        raise
    text = _finish(report, summary, out, config, rows_before, clock)
    print(text, end="", flush=True)
    return 0


def _finish(
    report: dict[str, Any],
    summary: dict[str, Any],
    out: Path,
    config: Any,
    rows_before: int,
    clock: float,
) -> str:
    """Complete `report` with what the run folder holds and write gpu_run.json/.txt."""
    train_csv = read_columns(out / "train.csv")
    iterations = summary.get("iterations")
    report |= {
        "finished": _utc(),
        "wall_seconds": round(time.perf_counter() - clock, 2),
        "iterations": iterations,
        # the iteration this call started at: each iteration trained adds one row
        "start_iteration": None
        if iterations is None
        else iterations - (len(train_csv.get("iteration", [])) - rows_before),
        "env_steps": summary.get("env_steps"),
        "stopped_by_time": None if iterations is None else iterations < config.run.iterations,
        "train_seconds": summary.get("seconds"),
        "throughput": throughput(train_csv, rows_before),
        "train_last": summary.get("train"),
        "priors": summary.get("priors"),
        "train_csv": train_csv,
        "eval_csv": read_columns(out / "eval.csv"),
    }
    report.setdefault("final_evaluation", summary.get("eval"))
    try:
        return write_reports(report, out)
    except OSError as exc:  # keep the training error, if any, the one reported
        print(f"gpu_run: could not write the reports in {out}: {exc}", file=sys.stderr)
        return ""


def print_flush(line: str) -> None:
    print(line, flush=True)


def main(argv: list[str] | None = None) -> int:
    clock, started = time.perf_counter(), _utc()
    args = parse_args(argv)
    try:
        return run(args, clock, started)
    except MotionkitError as exc:
        message = " ".join(str(exc).split())
        print(f"error: {message}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
