"""A run's curriculum: which stage of the recipe's [curriculum.NAME] tables trains now, when the
next one begins, and the record of each switch (OUT/curriculum.json, written with every
checkpoint so that a resumed run goes on in the stage its checkpoint was in).

A stage ends at the first evaluation that meets all its goals (for `hold` evaluations in a row,
after `min_iterations` in the stage), or after `max_iterations` in it; the last stage runs to
the end of the run. A goal names an evaluation figure (an eval.csv column, deterministic) or a
training figure (a train.csv column: its mean over the iterations since the previous
evaluation, under the policy's exploration noise).
"""

from __future__ import annotations

import json
import math
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path

from motionkit.core.errors import TrainError
from motionkit.files.outputs import write_json_atomic
from motionkit.train.config import StageConfig, TrainConfig, parse_goal

FILE = "curriculum.json"


@dataclass(frozen=True)
class CurriculumState:
    """Where a run is in its curriculum."""

    stage: int = 0  # index into the recipe's stages
    since: int = 0  # the iteration the stage began at
    held: int = 0  # evaluations in a row that met the stage's goals
    switches: tuple[dict, ...] = field(default_factory=tuple)  # iteration, from, to, why


def stage_names(config: TrainConfig) -> list[str]:
    return list(config.curriculum)


def stage_config(config: TrainConfig, state: CurriculumState) -> TrainConfig:
    """The config the run trains with now (the recipe itself without a curriculum)."""
    names = stage_names(config)
    return config.stage(names[state.stage]) if names else config


def goal_figures(evaluation: dict[str, float], window: list[dict[str, float]]) -> dict[str, float]:
    """The figures goals may name: the evaluation's, and each training figure's mean over
    `window` (the iterations since the previous evaluation; non-finite values left out)."""
    figures = dict(evaluation)
    for name in {name for row in window for name in row}:
        values = [row[name] for row in window if math.isfinite(row.get(name, math.nan))]
        figures[name] = sum(values) / len(values) if values else math.nan
    return figures


def goals_met(stage: StageConfig, evaluation: dict[str, float]) -> list[str]:
    """The goals met by `evaluation` (`goal_figures`), as 'figure value op x' lines;
    TrainError for a goal on a figure it does not hold."""
    met = []
    for name, goal in stage.goals.items():
        if name not in evaluation:
            raise TrainError(
                f"curriculum goal on {name!r}: no such evaluation or training figure "
                f"(known: {', '.join(sorted(evaluation))})"
            )
        operator, threshold = parse_goal(name, goal)
        value = evaluation[name]
        ok = value >= threshold if operator == ">=" else value <= threshold
        if ok and math.isfinite(value):
            met.append(f"{name} {value:.3g} {operator} {threshold:g}")
    return met


def advance(
    config: TrainConfig,
    state: CurriculumState,
    iteration: int,
    evaluation: dict[str, float] | None,
) -> tuple[CurriculumState, str]:
    """The state after `iteration` (and its evaluation, if one ran), and the reason of a switch
    to the next stage ('' when the stage goes on)."""
    names = stage_names(config)
    if state.stage >= len(names) - 1:
        return state, ""
    stage = config.curriculum[names[state.stage]]
    ran = iteration - state.since
    why = ""
    if evaluation is not None and stage.goals and ran >= stage.min_iterations:
        met = goals_met(stage, evaluation)
        held = state.held + 1 if len(met) == len(stage.goals) else 0
        state = replace(state, held=held)
        if held >= stage.hold:
            why = "goals met: " + ", ".join(met)
    if not why and stage.max_iterations and ran >= stage.max_iterations:
        why = f"{stage.max_iterations} iterations in the stage"
    if not why:
        return state, ""
    switch = {"iteration": iteration, "from": names[state.stage], "to": names[state.stage + 1]}
    switch["why"] = why
    return CurriculumState(state.stage + 1, iteration, 0, (*state.switches, switch)), why


def read_state(out: Path, config: TrainConfig) -> CurriculumState | None:
    """The state saved with the checkpoint in `out`; None without one (a checkpoint from
    another run, or a run without a curriculum)."""
    path = Path(out) / FILE
    if not path.is_file():
        return None
    try:
        data = json.loads(path.read_text())
        state = CurriculumState(
            int(data["stage"]), int(data["since"]), int(data["held"]), tuple(data["switches"])
        )
    except (ValueError, KeyError, TypeError) as exc:
        raise TrainError(f"{path}: not a curriculum state ({exc})") from exc
    names = stage_names(config)
    if names and (state.stage >= len(names) or data.get("name") != names[state.stage]):
        raise TrainError(
            f"{path}: stage {data.get('name')!r} is not stage {state.stage} of the config's "
            f"curriculum ({', '.join(names)})"
        )
    return state


def write_state(out: Path, config: TrainConfig, state: CurriculumState) -> None:
    names = stage_names(config)
    name = names[state.stage] if names else None
    write_json_atomic(Path(out) / FILE, asdict(state) | {"name": name})
