"""The paper's prior ablation: one config trained with both priors, walk only, flight only and
no prior; their final evaluations compared on a radar chart (episode duration, reward, thrust
usage), each axis scaled by the largest value of the four, and in a table of the figures that
say how each setting got there (waypoints, airborne share, falls, speed)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from motionkit.core.errors import TrainError
from motionkit.files.outputs import atomic_output, claim_out, write_text_atomic
from motionkit.robot import Robot
from motionkit.runtime.progress import Progress, silent
from motionkit.train.config import TrainConfig

SETTINGS = {
    "walk+flight": ["walk", "flight"],
    "walk": ["walk"],
    "flight": ["flight"],
    "none": [],
}
AXES = {  # radar axis -> evaluation figure
    "episode duration [s]": "eval_episode_seconds",
    "task reward": "eval_task_reward",
    "thrust usage": "eval_thrust_usage",
}
OUTPUTS = ("ablation.json", "ablation.md", "ablation.png")
TABLE = {  # table column -> evaluation figure
    **AXES,
    "waypoints per episode": "eval_waypoints_per_episode",
    "airborne share": "eval_airborne_share",
    "falls per episode": "eval_falls_per_episode",
    "speed to waypoint [m/s]": "eval_approach_speed",
}


def run_ablation(
    config: TrainConfig,
    out: Path,
    robot: Robot,
    progress: Progress = silent,
) -> dict[str, Any]:
    """Train the four prior settings, then compare their final evaluations.

    Each setting (walk+flight, walk, flight, none) trains into OUT/<setting>/ ("+" as "_"); a
    setting with a summary.json there is kept. Then OUT/ablation.json (every final
    evaluation), OUT/ablation.md (their table) and OUT/ablation.png (the radar chart) are
    written.

    Args:
        config: the training config, with both [priors.walk] and [priors.flight].
        out: the ablation's folder (OUT).
        robot: the robot to train.
        progress: called with each line of progress.

    Returns:
        "settings" (setting -> its priors), "figures" (setting -> radar axis -> value),
        "evaluations" (setting -> its final evaluation) and "table" (the Markdown table).

    Raises:
        TrainError: a config without the walk or flight prior, an `out` that holds files
            motionkit did not write, or any error of a setting's training run.
    """
    from motionkit.train.runner import train

    missing = [name for name in ("walk", "flight") if name not in config.priors]
    if missing:
        raise TrainError(f"the ablation needs [priors.walk] and [priors.flight]; missing {missing}")
    out = Path(out)
    folders = {setting: setting.replace("+", "_") for setting in SETTINGS}
    claim_out(out, [*folders.values(), *OUTPUTS], TrainError)
    evaluations: dict[str, dict[str, float]] = {}
    for setting, priors in SETTINGS.items():
        folder = out / folders[setting]
        summary_path = folder / "summary.json"
        if summary_path.exists():
            progress(f"{setting}: kept the finished run in {folder}")
            summary = json.loads(summary_path.read_text())
        else:
            progress(f"{setting}: training into {folder}")
            summary = train(config.select_priors(priors), folder, robot, progress=progress)
        evaluations[setting] = summary.get("eval") or {}
    figures = {
        setting: {axis: float(evaluation.get(key, 0.0)) for axis, key in AXES.items()}
        for setting, evaluation in evaluations.items()
    }
    table = metrics_table(evaluations)
    result = {"settings": dict(SETTINGS), "figures": figures, "evaluations": evaluations}
    write_text_atomic(out / "ablation.json", json.dumps(result, indent=2) + "\n")
    write_text_atomic(out / "ablation.md", table)
    radar_chart(out / "ablation.png", figures)
    return result | {"table": table}


def metrics_table(evaluations: dict[str, dict[str, float]]) -> str:
    """A Markdown table: one row per setting, one column per figure of TABLE ("n/a" where the
    evaluation lacks it or it is not a number, e.g. the time to a waypoint never reached)."""

    def cell(value: Any) -> str:
        return f"{value:.3g}" if isinstance(value, int | float) and value == value else "n/a"

    lines = [
        "| setting | " + " | ".join(TABLE) + " |",
        "|---" * (len(TABLE) + 1) + "|",
    ]
    for setting, evaluation in evaluations.items():
        cells = (cell(evaluation.get(key)) for key in TABLE.values())
        lines.append(f"| {setting} | " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


def radar_chart(path: Path, figures: dict[str, dict[str, float]]) -> None:
    """One polygon per setting over the axes, each axis divided by its largest |value|."""
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
        import numpy as np
    except ImportError as exc:
        raise TrainError("the radar chart needs matplotlib (the [train] extra)") from exc
    axes = list(next(iter(figures.values())))
    scale = {a: max(abs(f[a]) for f in figures.values()) or 1.0 for a in axes}
    angles = np.linspace(0, 2 * np.pi, len(axes), endpoint=False).tolist()
    figure, ax = plt.subplots(figsize=(6, 6), subplot_kw={"polar": True})
    for setting, values in figures.items():
        radii = [values[a] / scale[a] for a in axes]
        ax.plot([*angles, angles[0]], [*radii, radii[0]], label=setting)
        ax.fill([*angles, angles[0]], [*radii, radii[0]], alpha=0.1)
    ax.set_xticks(angles)
    ax.set_xticklabels([f"{a}\n(max {scale[a]:.3g})" for a in axes])
    ax.set_ylim(min(0.0, *(v[a] / scale[a] for v in figures.values() for a in axes)), 1.0)
    ax.set_title("Prior ablation (final evaluation, scaled per axis)")
    ax.legend(loc="upper right", bbox_to_anchor=(1.3, 1.1))
    with atomic_output(Path(path)) as stream:
        figure.savefig(stream, format="png", dpi=100, bbox_inches="tight")
    plt.close(figure)
