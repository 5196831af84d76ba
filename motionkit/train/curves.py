"""A run's training curves as one PNG: the gait, waypoint, flight, discriminator and reward
figures of OUT/train.csv (per iteration, with a running mean) and OUT/eval.csv (the
deterministic evaluations, as points), over env-steps; a run on a course adds a panel of the
mean level of each kind of tile (the curriculum of levels)."""

from __future__ import annotations

import csv
import math
from pathlib import Path

import numpy as np

from motionkit.core.errors import TrainError
from motionkit.files.outputs import atomic_output

# panel title -> the columns it draws (train.csv names; eval.csv has them with "eval_")
PANELS: dict[str, tuple[str, ...]] = {
    "speed toward the waypoint [m/s]": ("approach_speed",),
    "single support share": ("single_support_share",),
    "contact switches per second": ("contact_switches_per_second",),
    "falls per episode": ("falls_per_episode",),
    "waypoints per episode": ("waypoints_per_episode", "air_waypoints_per_episode"),
    "airborne share": ("airborne_share", "airborne_share_to_ground", "airborne_share_to_air"),
    "thrust usage T / T_max": ("thrust_usage", "thrust_usage_airborne"),
    "discriminator accuracy": ("disc_policy_accuracy", "disc_expert_accuracy"),
    "rewards": ("task_reward", "style_reward"),
}
LEVELS = "terrain_level_"  # the prefix of a course's mean level per kind
COLORS = ("C0", "C1", "C2", "C3", "C4", "C5")


def read_table(path: Path) -> dict[str, np.ndarray]:
    """The columns of a metrics CSV as float arrays (empty cells: NaN); {} when it is absent."""
    if not path.exists():
        return {}
    with path.open(newline="") as stream:
        rows = list(csv.DictReader(stream))
    if not rows:
        return {}
    return {name: np.array([_number(r[name]) for r in rows]) for name in rows[0]}


def running_mean(values: np.ndarray, window: int) -> np.ndarray:
    """The mean of the last `window` finite values at each index (NaN where there are none)."""
    finite = np.isfinite(values)
    sums = np.cumsum(np.where(finite, values, 0.0))
    counts = np.cumsum(finite)
    start = np.arange(len(values)) - window
    lagged = np.where(start >= 0, sums[np.maximum(start, 0)], 0.0)
    lagged_counts = np.where(start >= 0, counts[np.maximum(start, 0)], 0)
    n = counts - lagged_counts
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(n > 0, (sums - lagged) / n, np.nan)


def draw_curves(run: Path, path: Path | None = None) -> Path:
    """Draw RUN/train.csv and RUN/eval.csv into `path` (default RUN/curves.png).

    One panel per entry of PANELS over env-steps: the training figures per iteration with a
    running mean, the evaluations as points, a curriculum's stage switches as dotted lines.

    Args:
        run: the training run's folder.
        path: the PNG to write (None: RUN/curves.png).

    Returns:
        The PNG's path.

    Raises:
        TrainError: no train.csv with env_steps in `run`, or no matplotlib.
    """
    train = read_table(run / "train.csv")
    if "env_steps" not in train:
        raise TrainError(f"{run}: no train.csv with env_steps to draw")
    try:  # a Figure of its own, not pyplot: a notebook's backend and figures stay as they are
        from matplotlib.figure import Figure
    except ImportError as exc:
        raise TrainError("the training curves need matplotlib (the [train] extra)") from exc
    evaluation = read_table(run / "eval.csv")
    steps = train["env_steps"] / 1e6
    eval_steps = np.interp(evaluation.get("iteration", []), train["iteration"], steps)
    window = max(1, len(steps) // 50)
    panels = dict(PANELS)
    levels = tuple(name for name in train if name.startswith(LEVELS))
    if levels:
        panels["terrain level (mean per kind)"] = levels
    rows = math.ceil(len(panels) / 3)
    figure = Figure(figsize=(13, 3 * rows))
    axes = figure.subplots(rows, 3, sharex=True, squeeze=False)
    for ax in axes.flat[len(panels) :]:
        ax.set_visible(False)
    for ax, (title, columns) in zip(axes.flat, panels.items(), strict=False):
        for color, column in zip(COLORS, columns, strict=False):
            label = column.replace("disc_", "").replace(LEVELS, "").replace("_", " ")
            if column in train:
                ax.plot(steps, train[column], color=color, alpha=0.2, linewidth=0.5)
                ax.plot(steps, running_mean(train[column], window), color=color, label=label)
            if f"eval_{column}" in evaluation:
                ax.plot(eval_steps, evaluation[f"eval_{column}"], "o", color=color, markersize=4)
        for switch in _stage_switches(train):
            ax.axvline(switch, color="grey", linestyle=":", linewidth=1)
        ax.set_title(title, fontsize=10)
        ax.grid(alpha=0.3)
        if len(columns) > 1 and ax.get_legend_handles_labels()[0]:
            ax.legend(fontsize=8)
    for ax in list(axes.flat[: len(panels)])[-3:]:  # the lowest panel of each column
        ax.set_xlabel("env-steps [M]")
    switches = " and curriculum stages (dotted)" if len(_stage_switches(train)) else ""
    figure.suptitle(
        f"{run.name}: training (line: running mean of {window} iterations) and "
        f"deterministic evaluations (points){switches}"
    )
    figure.tight_layout()
    path = run / "curves.png" if path is None else path
    with atomic_output(path) as stream:
        figure.savefig(stream, format="png", dpi=90)
    return path


def _stage_switches(train: dict[str, np.ndarray]) -> np.ndarray:
    """The env-steps [M] at which a curriculum's next stage began (none without one)."""
    stage = train.get("stage")
    if stage is None or len(stage) < 2:
        return np.zeros(0)
    return train["env_steps"][1:][np.diff(stage) != 0] / 1e6


def _number(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        return math.nan
    return value
