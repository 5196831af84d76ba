"""The walking, flying and switching goals of the flat scenario, read off a run's evaluations
(eval.csv): the first evaluation that meets each, with the env-steps and the wall time it took
(train.csv). The figures are the deterministic evaluation's from standing starts.

walking    ground waypoints walked: airborne at most 20 % of the way, on one foot at least
           25 % of the time, at least 3 waypoints per episode, at most 0.05 falls per episode
flying     air waypoints flown: airborne at least 50 % of the way, at least 1 air waypoint
           per episode, at most 0.05 falls per episode
switching  both in one evaluation with half the waypoints in the air (walking's and flying's
           figures at once, at least 3 waypoints per episode)
gait       switching, with the jets idle on the way to ground waypoints (each jet at most 5 %
           of T_max), at most 1.56 contact switches per foot per second (1.5 times the walking
           prior's 1.04) and the feet's stance shares within 10 % of each other
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from motionkit.train.curves import read_table

Goal = dict[str, tuple[str, float]]

WALKING: Goal = {
    "eval_airborne_share_to_ground": ("<=", 0.2),
    "eval_single_support_share": (">=", 0.25),
    "eval_waypoints_per_episode": (">=", 3.0),
    "eval_falls_per_episode": ("<=", 0.05),
}
FLYING: Goal = {
    "eval_airborne_share_to_air": (">=", 0.5),
    "eval_air_waypoints_per_episode": (">=", 1.0),
    "eval_falls_per_episode": ("<=", 0.05),
}
SWITCHING: Goal = WALKING | FLYING
GAIT: Goal = SWITCHING | {
    "eval_thrust_usage_to_ground_max_jet": ("<=", 0.05),
    "eval_contact_switches_per_second": ("<=", 1.56),
}
GOALS: dict[str, Goal] = {
    "walking": WALKING,
    "flying": FLYING,
    "switching": SWITCHING,
    "gait": GAIT,
}
STANCE_RATIO = 0.9  # the less-used foot is down at least 90 % as often as the other


def meets(goal: Goal, row: dict[str, float]) -> bool:
    """Whether one evaluation's figures meet every figure of the goal (a missing or NaN
    figure does not). The gait goal also asks for even stance shares."""
    for name, (operator, threshold) in goal.items():
        value = row.get(name, math.nan)
        if not math.isfinite(value):
            return False
        if not (value >= threshold if operator == ">=" else value <= threshold):
            return False
    if goal is GAIT:
        low, high = row.get("eval_stance_share_min_foot"), row.get("eval_stance_share_max_foot")
        if low is None or high is None or not (high > 0 and low >= STANCE_RATIO * high):
            return False
    return True


def cumulative_wall_seconds(wall: np.ndarray) -> np.ndarray:
    """train.csv's wall_seconds (counted from each session's start) as one running total over
    the sessions of a resumed run: where the clock falls back, a new session began."""
    total = np.empty_like(wall)
    offset = 0.0
    for i, seconds in enumerate(wall):
        if i and seconds < wall[i - 1]:
            offset += wall[i - 1]
        total[i] = offset + seconds
    return total


def time_to_goals(run: Path) -> dict[str, dict[str, float] | None]:
    """Per goal, the first evaluation of RUN that meets it: its iteration, env-steps and the
    run's wall seconds up to it (all sessions); None where no evaluation does."""
    evaluations, training = read_table(run / "eval.csv"), read_table(run / "train.csv")
    if not evaluations or not training:
        raise FileNotFoundError(f"{run}: no eval.csv or train.csv with rows")
    iterations = training["iteration"]
    wall = cumulative_wall_seconds(training["wall_seconds"])
    count = len(evaluations["iteration"])
    rows = [{name: column[i] for name, column in evaluations.items()} for i in range(count)]
    reached: dict[str, dict[str, float] | None] = {}
    for goal_name, goal in GOALS.items():
        first = next((row for row in rows if meets(goal, row)), None)
        if first is None:
            reached[goal_name] = None
            continue
        index = int(np.searchsorted(iterations, first["iteration"]))
        index = min(index, len(iterations) - 1)
        reached[goal_name] = {
            "iteration": first["iteration"],
            "env_steps": float(training["env_steps"][index]),
            "wall_seconds": float(wall[index]),
        }
    return reached
