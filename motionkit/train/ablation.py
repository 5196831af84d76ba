"""The paper's prior ablation over seeds: one config trained with both priors, walk only,
flight only and no prior (the arms), each with every seed, one run at a time and resumable;
their final evaluations compared per arm (mean and min-max spread over the seeds) in a table,
on a radar chart and as learning curves.

OUT/<arm>/seed_<s>/      a run of `motionkit.train.runner.train` ("+" of an arm's name as "_")
OUT/ablation.json        every run's final evaluation, per arm and seed, and the statistics
OUT/ablation.md          the table: per arm, mean [min, max] over its finished runs
OUT/ablation.png         the radar chart: per arm the mean, and the min-max band
OUT/ablation_curves.png  every run's evaluations over env-steps, per arm the mean and band

The radar's quantities, each in [0, 1] for a good run: the episode duration over the maximum
episode length ([env] episode_seconds of the run's curriculum stage), the task reward over the
largest |task reward| among the finished runs, and the thrust usage as the paper defines it,
1 - T/T_max, where T/T_max is the evaluation's eval_thrust_usage (the thrust per T_max averaged
over the jets and steps): 1 for jets held off, 0 for jets at full thrust all along.
"""

from __future__ import annotations

import json
import math
import time
import warnings
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from motionkit.core.errors import TrainError
from motionkit.files.outputs import atomic_output, claim_out, write_json_atomic, write_text_atomic
from motionkit.robot import Robot
from motionkit.runtime.progress import Progress, silent
from motionkit.train.config import TrainConfig

ARMS = {  # arm -> the priors it trains with
    "walk+flight": ["walk", "flight"],
    "walk": ["walk"],
    "flight": ["flight"],
    "none": [],
}
OUTPUTS = ("ablation.json", "ablation.md", "ablation.png", "ablation_curves.png")
RADAR = ("episode duration / max", "task reward / max", "thrust usage 1 - T/T_max")
TABLE = {  # table column -> evaluation figure (the radar's three are derived, `run_figures`)
    RADAR[0]: "eval_episode_seconds",
    RADAR[1]: "eval_task_reward",
    RADAR[2]: "eval_thrust_usage",
    "waypoints per episode": "eval_waypoints_per_episode",
    "airborne share to ground": "eval_airborne_share_to_ground",
    "airborne share to air": "eval_airborne_share_to_air",
    "falls per episode": "eval_falls_per_episode",
}
CURVES = {  # learning-curve panel -> evaluation figure ("1 - " drawn as 1 - the figure)
    "waypoints per episode": "eval_waypoints_per_episode",
    "airborne share to ground": "eval_airborne_share_to_ground",
    "airborne share to air": "eval_airborne_share_to_air",
    "falls per episode": "eval_falls_per_episode",
    "thrust usage 1 - T/T_max": "1 - eval_thrust_usage",
}
COLORS = {"walk+flight": "C0", "walk": "C1", "flight": "C2", "none": "C3"}
_clock = time.monotonic  # the call's clock, seconds (a test may stand in for it)


def run_folder(out: Path, arm: str, seed: int) -> Path:
    """The folder of one run: OUT/<arm>/seed_<s>/, with "+" of the arm's name as "_"."""
    return Path(out) / arm.replace("+", "_") / f"seed_{seed}"


def arm_config(config: TrainConfig, arm: str, seed: int, minutes: float = 0.0) -> TrainConfig:
    """The config of one run: the arm's priors alone (`select_priors` drops the others from
    [priors] and from every curriculum stage's weights), the seed, and at most `minutes` of
    wall time (0: the config's [run] max_minutes as it is)."""
    selected = config.select_priors(ARMS[arm])
    run = replace(selected.run, seed=seed)
    if minutes > 0:
        run = replace(run, max_minutes=min(run.max_minutes or math.inf, minutes))
    return replace(selected, run=run)


@dataclass(frozen=True)
class RunState:
    """What a run folder holds: a checkpoint to resume from, and whether the run finished."""

    checkpoint: bool = False
    finished: bool = False
    iterations: int = 0  # the summary's (0 without one)


def run_state(folder: Path, iterations: int) -> RunState:
    """The state of a run folder: finished when its summary.json exists and the summary's and
    the checkpoint's iteration reached `iterations`."""
    from motionkit.train.checkpoint import NAME

    checkpoint, summary_path = folder / NAME, folder / "summary.json"
    if not checkpoint.is_file():
        return RunState()
    if not summary_path.is_file():
        return RunState(checkpoint=True)
    try:
        done = int(json.loads(summary_path.read_text())["iterations"])
    except (ValueError, KeyError, TypeError) as exc:
        raise TrainError(f"{summary_path}: not a run's summary ({exc})") from exc
    finished = done >= iterations and checkpoint_iteration(checkpoint) >= iterations
    return RunState(checkpoint=True, finished=finished, iterations=done)


def checkpoint_iteration(path: Path) -> int:
    """The iteration a checkpoint was saved at (without building its networks)."""
    from flax import serialization

    try:
        return int(serialization.msgpack_restore(path.read_bytes())["iteration"])
    except Exception as exc:  # msgpack's errors for truncated or foreign bytes
        raise TrainError(f"{path}: not a checkpoint ({exc})") from exc


def run_ablation(
    config: TrainConfig,
    out: Path,
    robot: Robot,
    seeds: list[int] | None = None,
    *,
    resume: bool = False,
    max_minutes: float = 0.0,
    progress: Progress = silent,
) -> dict[str, Any]:
    """Train every arm with every seed into OUT/<arm>/seed_<s>/, then compare them.

    The runs go seed-major (every arm with the first seed, then with the next), one at a time.
    With `resume`, a finished run is kept, an unfinished one (a checkpoint short of [run]
    iterations) goes on from its checkpoint and a missing one starts; without it, an OUT that
    holds runs is refused. The outputs (module doc) are written after each run that ended and
    at the end; the table and radar count finished runs, the curves every run.

    Args:
        config: the training config, with [priors.walk] and [priors.flight].
        out: the ablation's folder (OUT).
        robot: the robot to train.
        seeds: the seeds of every arm (None: the config's [run] seed alone).
        resume: go on with the runs in OUT.
        max_minutes: wall time for the whole call (0: none); the run in training when it is
            spent stops (its [run] max_minutes is what is left), and no run starts after.
        progress: called with each line of progress.

    Returns:
        "arms", "seeds", "runs" (arm -> seed -> figures, ablation.json's), "statistics",
        "table" (ablation.md), "finished" (runs finished) and "total" (runs planned).

    Raises:
        TrainError: a config without the walk or flight prior, bad seeds, runs in OUT
            without `resume`, an OUT that holds files motionkit did not write, or any
            error of a run.
    """
    started = _clock()
    out = Path(out)
    seeds = _check(config, out, seeds, resume)
    claim_out(out, [*(a.replace("+", "_") for a in ARMS), *OUTPUTS], TrainError)
    for arm in ARMS:
        claim_out(run_folder(out, arm, 0).parent, [f"seed_{s}" for s in seeds], TrainError)
    deadline = started + 60 * max_minutes if max_minutes > 0 else math.inf
    call = _Call(config, out, robot, progress, started, deadline)
    plan = [(arm, seed) for seed in seeds for arm in ARMS]
    result = None  # the outputs as last written (None: not yet, or out of date)
    for number, (arm, seed) in enumerate(plan, 1):
        outcome = _train_one(call, arm, seed, f"{arm} seed {seed} (run {number} of {len(plan)})")
        if outcome == "spent":
            break
        if outcome == "trained":
            result = write_outputs(config, out, seeds)
    result = result or write_outputs(config, out, seeds)
    line = f"ablation: {result['finished']} of {result['total']} runs finished ({call.used()})"
    progress(line + ("" if result["finished"] == result["total"] else "; --resume goes on"))
    return result


def _check(config: TrainConfig, out: Path, seeds: list[int] | None, resume: bool) -> list[int]:
    """The seeds to run; TrainError for a config without both priors, bad seeds or, without
    `resume`, an OUT that holds runs (checked before anything is written)."""
    missing = [name for name in ("walk", "flight") if name not in config.priors]
    if missing:
        raise TrainError(f"the ablation needs [priors.walk] and [priors.flight]; missing {missing}")
    seeds = [config.run.seed] if seeds is None else list(seeds)
    if not seeds or len(set(seeds)) != len(seeds) or min(seeds) < 0:
        raise TrainError(f"seeds {seeds}: expected distinct seeds >= 0")
    if not resume:
        held = [
            str(run_folder(out, arm, seed).relative_to(out))
            for seed in seeds
            for arm in ARMS
            if run_state(run_folder(out, arm, seed), config.run.iterations).checkpoint
        ]
        if held:
            raise TrainError(
                f"{out} holds ablation runs already ({', '.join(held)}): pass --resume to go "
                "on with them, or another --out"
            )
    return seeds


@dataclass(frozen=True)
class _Call:
    """One call of `run_ablation`: what every run shares, and its clock."""

    config: TrainConfig
    out: Path
    robot: Robot
    progress: Progress
    started: float  # _clock() at the call
    deadline: float  # _clock() at which the call's time is spent (inf: never)

    def used(self) -> str:
        used = (_clock() - self.started) / 60
        if math.isinf(self.deadline):
            return f"{used:.1f} min in this call"
        return f"{used:.1f} of {(self.deadline - self.started) / 60:.1f} min in this call"


def _train_one(call: _Call, arm: str, seed: int, label: str) -> str:
    """Keep, resume or start one run: "kept", "trained", or "spent" (the call's time was
    spent before it, nothing done)."""
    from motionkit.train.runner import train

    folder = run_folder(call.out, arm, seed)
    target = call.config.run.iterations
    state = run_state(folder, target)
    if state.finished:
        call.progress(f"{label}: kept, finished at iteration {state.iterations} in {folder}")
        return "kept"
    left = call.deadline - _clock()
    if left <= 0:
        call.progress(f"ablation: the time of this call is spent before {label}")
        return "spent"
    minutes = 0.0 if math.isinf(left) else left / 60
    verb = "resuming" if state.checkpoint else "starting"
    budget = f" (at most {minutes:.1f} min)" if minutes else ""
    call.progress(f"{label}: {verb} in {folder}{budget}")
    run_config = arm_config(call.config, arm, seed, minutes)
    summary = train(run_config, folder, call.robot, resume=state.checkpoint, progress=call.progress)
    done = int(summary["iterations"])
    end = "finished" if done >= target else f"stopped at iteration {done} of {target}"
    call.progress(f"{label}: {end} after {summary['seconds'] / 60:.1f} min; {call.used()}")
    return "trained"


def write_outputs(config: TrainConfig, out: Path, seeds: list[int]) -> dict[str, Any]:
    """Read every run's summary and write OUT/ablation.json, .md, .png and _curves.png (the
    radar needs a finished run, the curves an evaluation); returns `run_ablation`'s result."""
    runs = collect_runs(config, out, seeds)
    figures = run_figures(runs)
    statistics = arm_statistics(figures)
    table = metrics_table(statistics, len(seeds))
    finished = sum(len(by_seed) for by_seed in figures.values())
    result = {
        "arms": dict(ARMS),
        "seeds": list(seeds),
        "iterations": config.run.iterations,
        "spread": "min and max over the arm's finished runs",
        "runs": runs,
        "statistics": statistics,
        "finished": finished,
        "total": len(ARMS) * len(seeds),
    }
    write_json_atomic(out / "ablation.json", result)
    write_text_atomic(out / "ablation.md", table)
    if finished:
        radar_chart(out / "ablation.png", figures)
    folders = {arm: {s: run_folder(out, arm, s) for s in seeds} for arm in ARMS}
    curves_chart(out / "ablation_curves.png", folders)
    return result | {"table": table}


def collect_runs(config: TrainConfig, out: Path, seeds: list[int]) -> dict[str, dict[str, Any]]:
    """arm -> seed (as text) -> the run's folder, whether it finished, its iterations and
    env-steps, the maximum episode length of its stage and its last evaluation."""
    runs: dict[str, dict[str, Any]] = {}
    for arm in ARMS:
        runs[arm] = {}
        for seed in seeds:
            folder = run_folder(out, arm, seed)
            summary_path = folder / "summary.json"
            if not summary_path.is_file():
                continue
            summary = json.loads(summary_path.read_text())
            runs[arm][str(seed)] = {
                "folder": str(folder.relative_to(out)),
                "finished": run_state(folder, config.run.iterations).finished,
                "iterations": summary.get("iterations"),
                "env_steps": summary.get("env_steps"),
                "episode_seconds": _episode_seconds(folder, config),
                "eval": summary.get("eval") or {},
            }
    return runs


def _episode_seconds(folder: Path, config: TrainConfig) -> float:
    """The maximum episode length of the curriculum stage the run's checkpoint is in."""
    from motionkit.train import curriculum

    try:
        state = curriculum.read_state(folder, config)
    except TrainError:
        state = None
    if state is None and config.curriculum:  # a run without its state: the last stage
        state = curriculum.CurriculumState(stage=len(config.curriculum) - 1)
    return curriculum.stage_config(
        config, state or curriculum.CurriculumState()
    ).env.episode_seconds


def _number(value: Any) -> float:
    """A figure as a float (None, a missing figure or text: NaN)."""
    return float(value) if isinstance(value, int | float) else math.nan


def run_figures(runs: dict[str, dict[str, Any]]) -> dict[str, dict[str, dict[str, float]]]:
    """arm -> seed -> TABLE column -> value, for the finished runs: the radar's three scaled
    (episode duration / episode_seconds, task reward / the largest |task reward| of them,
    1 - eval_thrust_usage), the others as evaluated."""
    finished = {
        arm: {seed: run for seed, run in by_seed.items() if run["finished"]}
        for arm, by_seed in runs.items()
    }
    rewards = [
        abs(_number(run["eval"].get(TABLE[RADAR[1]])))
        for by_seed in finished.values()
        for run in by_seed.values()
    ]
    scale = max((r for r in rewards if math.isfinite(r)), default=0.0) or 1.0
    figures: dict[str, dict[str, dict[str, float]]] = {}
    for arm, by_seed in finished.items():
        figures[arm] = {}
        for seed, run in by_seed.items():
            values = {c: _number(run["eval"].get(key)) for c, key in TABLE.items()}
            values[RADAR[0]] /= run["episode_seconds"]
            values[RADAR[1]] /= scale
            values[RADAR[2]] = 1.0 - values[RADAR[2]]
            figures[arm][seed] = values
    return figures


def arm_statistics(
    figures: dict[str, dict[str, dict[str, float]]],
) -> dict[str, dict[str, dict[str, float]]]:
    """arm -> column -> mean, min and max over the arm's runs where the figure is a number,
    "runs" (how many) and "of" (the arm's runs); NaN statistics where none is."""
    statistics: dict[str, dict[str, dict[str, float]]] = {}
    for arm, by_seed in figures.items():
        statistics[arm] = {}
        for column in TABLE:
            values = np.array([run[column] for run in by_seed.values()], dtype=float)
            values = values[np.isfinite(values)]
            some = len(values) > 0
            statistics[arm][column] = {
                "mean": float(values.mean()) if some else math.nan,
                "min": float(values.min()) if some else math.nan,
                "max": float(values.max()) if some else math.nan,
                "runs": len(values),
                "of": len(by_seed),
            }
    return statistics


def metrics_table(statistics: dict[str, dict[str, dict[str, float]]], seeds: int) -> str:
    """A Markdown table: one row per arm, its finished runs (of `seeds`) and per TABLE column
    "mean [min, max]" over them; "(k)" after it when only k of them have the figure (an
    airborne share to air needs an air waypoint in the evaluation), "n/a" when none has."""

    def cell(stats: dict[str, float]) -> str:
        if not stats["runs"]:
            return "n/a"
        text = f"{stats['mean']:.3g} [{stats['min']:.3g}, {stats['max']:.3g}]"
        return text if stats["runs"] == stats["of"] else f"{text} ({stats['runs']})"

    lines = [
        "| arm | runs | " + " | ".join(TABLE) + " |",
        "|---" * (len(TABLE) + 2) + "|",
    ]
    for arm in ARMS:
        by_column = statistics.get(arm, {})
        count = next(iter(by_column.values()), {}).get("of", 0)
        cells = (cell(by_column[c]) if count else "n/a" for c in TABLE)
        lines.append(f"| {arm} | {count} of {seeds} | " + " | ".join(cells) + " |")
    note = (
        "Per arm: mean [min, max] over its finished runs. Episode duration is over the maximum "
        "episode length, task reward over the largest |task reward| of the finished runs, "
        "thrust usage is 1 - T/T_max (1: jets off, 0: full thrust all along)."
    )
    return "\n".join(lines) + "\n\n" + note + "\n"


def _pyplot() -> Any:
    """matplotlib's Figure class on the Agg canvas (no pyplot state is touched)."""
    try:
        from matplotlib.figure import Figure
    except ImportError as exc:
        raise TrainError("the ablation's charts need matplotlib (the [train] extra)") from exc
    return Figure


def radar_chart(path: Path, figures: dict[str, dict[str, dict[str, float]]]) -> None:
    """One polygon per arm over RADAR: the mean of its runs, shaded between their min and max
    (`run_figures`' values: each quantity in [0, 1] for a good run)."""
    figure = _pyplot()(figsize=(6.5, 6.5))
    ax = figure.add_subplot(polar=True)
    angles = np.linspace(0, 2 * np.pi, len(RADAR), endpoint=False)
    closed = np.append(angles, angles[0])
    lowest = 0.0
    for arm, by_seed in figures.items():
        if not by_seed:
            continue
        values = np.array([[run[c] for c in RADAR] for run in by_seed.values()], dtype=float)
        values = np.nan_to_num(values, nan=0.0)
        mean, low, high = values.mean(0), values.min(0), values.max(0)
        lowest = min(lowest, float(low.min()))
        color = COLORS.get(arm)
        ax.plot(closed, np.append(mean, mean[0]), color=color, linewidth=2, label=arm)
        ax.fill_between(
            closed, np.append(low, low[0]), np.append(high, high[0]), color=color, alpha=0.2
        )
    ax.set_xticks(angles)
    ax.set_xticklabels(list(RADAR))
    ax.set_ylim(lowest, 1.0)
    ax.set_title("Prior ablation: final evaluation, mean over seeds (band: min-max)", pad=24)
    ax.legend(loc="upper left", bbox_to_anchor=(1.08, 1.0))
    with atomic_output(Path(path)) as stream:
        figure.savefig(stream, format="png", dpi=100, bbox_inches="tight")


def eval_curve(folder: Path, figure: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A run's evaluations of `figure` (CURVES' names): iterations, env-steps (train.csv's,
    at each evaluation's iteration) and values; empty arrays before its first evaluation."""
    from motionkit.train.curves import read_table

    train, evaluation = read_table(folder / "train.csv"), read_table(folder / "eval.csv")
    name = figure.removeprefix("1 - ")
    if "env_steps" not in train or "iteration" not in evaluation or name not in evaluation:
        empty = np.zeros(0)
        return empty, empty, empty
    at, steps = _last_rows(train["iteration"], train["env_steps"])
    iterations, values = _last_rows(evaluation["iteration"], evaluation[name])
    values = 1.0 - values if figure.startswith("1 - ") else values
    return iterations, np.interp(iterations, at, steps), values


def _last_rows(iterations: np.ndarray, values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The rows by increasing iteration, the last of each (a run resumed from an earlier
    checkpoint than it had reached logs some iterations twice)."""
    backwards = iterations[::-1]
    unique, first = np.unique(backwards, return_index=True)
    return unique, values[::-1][first]


def curves_chart(path: Path, folders: dict[str, dict[int, Path]]) -> None:
    """The learning curves of every run, a panel per CURVES figure over env-steps: a thin line
    per run, and per arm the mean and min-max band at the evaluations all its runs reached;
    nothing is written before a first evaluation."""
    curves = {  # arm -> panel title -> its runs' (iterations, env-steps, values)
        arm: {
            title: [eval_curve(folder, name) for folder in by_seed.values()]
            for title, name in CURVES.items()
        }
        for arm, by_seed in folders.items()
    }
    every = [run for by_title in curves.values() for one in by_title.values() for run in one]
    if not any(len(iterations) for iterations, _, _ in every):
        return
    figure = _pyplot()(figsize=(13, 7))
    axes = figure.subplots(2, 3, squeeze=False).flat
    for ax, title in zip(axes, CURVES, strict=False):
        for arm, by_title in curves.items():
            _draw_arm(ax, by_title[title], COLORS.get(arm), arm)
        ax.set_title(title, fontsize=10)
        ax.set_xlabel("env-steps [M]")
        ax.grid(alpha=0.3)
    handles, labels = axes[0].get_legend_handles_labels()
    axes[5].axis("off")
    axes[5].legend(handles, labels, loc="center", title="arm (mean; band: min-max)")
    figure.suptitle("Prior ablation: deterministic evaluations (thin: one run)")
    figure.tight_layout()
    with atomic_output(Path(path)) as stream:
        figure.savefig(stream, format="png", dpi=90)


def _draw_arm(ax: Any, runs: list[tuple[np.ndarray, ...]], color: str | None, arm: str) -> None:
    """One arm on a panel: its runs thin, their mean and min-max band over the iterations
    every run with an evaluation reached."""
    runs = [run for run in runs if len(run[0])]
    for _, steps, values in runs:
        ax.plot(steps / 1e6, values, color=color, alpha=0.35, linewidth=0.8)
    if not runs:
        return
    common = runs[0][0]
    for iterations, _, _ in runs[1:]:
        common = np.intersect1d(common, iterations)
    picked = [[run[k][np.isin(run[0], common)] for run in runs] for k in (1, 2)]
    steps, values = np.mean(picked[0], axis=0) / 1e6, np.array(picked[1])
    with np.errstate(invalid="ignore"), warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # an all-NaN evaluation
        mean, low, high = np.nanmean(values, 0), np.nanmin(values, 0), np.nanmax(values, 0)
    ax.plot(steps, mean, color=color, linewidth=2, marker="o", markersize=3, label=arm)
    ax.fill_between(steps, low, high, color=color, alpha=0.2)
