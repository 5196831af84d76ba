"""The walking, flying, switching and gait goals read off a run's logs: which evaluation meets
each first, and the env-steps and wall time (over resumed sessions) it took."""

import csv
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from motionkit.train.goals import GAIT, WALKING, cumulative_wall_seconds, meets, time_to_goals

ROOT = Path(__file__).resolve().parents[2]

WALKED = {
    "eval_airborne_share_to_ground": 0.1,
    "eval_single_support_share": 0.3,
    "eval_waypoints_per_episode": 3.5,
    "eval_falls_per_episode": 0.0,
    "eval_airborne_share_to_air": math.nan,  # no air waypoint in a walking evaluation
    "eval_air_waypoints_per_episode": 0.0,
}
FLOWN = WALKED | {"eval_airborne_share_to_air": 0.7, "eval_air_waypoints_per_episode": 1.5}
GAITED = FLOWN | {
    "eval_thrust_usage_to_ground_max_jet": 0.04,
    "eval_contact_switches_per_second": 1.4,
    "eval_stance_share_min_foot": 0.6,
    "eval_stance_share_max_foot": 0.65,
}


def write_csv(path: Path, rows: list[dict[str, float]]) -> None:
    with path.open("w", newline="") as stream:
        names = list(dict.fromkeys(k for row in rows for k in row))
        writer = csv.DictWriter(stream, fieldnames=names, restval="")
        writer.writeheader()
        writer.writerows(rows)


def test_a_goal_needs_every_figure_and_the_gait_even_feet() -> None:
    assert meets(WALKING, WALKED)
    assert not meets(WALKING, WALKED | {"eval_single_support_share": 0.2})
    assert not meets(WALKING, {k: v for k, v in WALKED.items() if k != "eval_falls_per_episode"})
    assert meets(GAIT, GAITED)
    # 0.58 / 0.65 = 0.89: one foot stands less than 90 % as often as the other
    assert not meets(GAIT, GAITED | {"eval_stance_share_min_foot": 0.58})
    assert not meets(GAIT, GAITED | {"eval_thrust_usage_to_ground_max_jet": 0.07})


def test_wall_time_adds_up_over_resumed_sessions() -> None:
    wall = np.array([10.0, 20.0, 30.0, 5.0, 15.0, 2.0])
    assert cumulative_wall_seconds(wall).tolist() == [10.0, 20.0, 30.0, 35.0, 45.0, 47.0]


@pytest.fixture
def run(tmp_path: Path) -> Path:
    """Six iterations over two sessions, evaluated at 2 (nothing), 4 (walking) and 6 (all)."""
    training = [
        {"iteration": i, "env_steps": 1000.0 * i, "wall_seconds": w}
        for i, w in zip(range(1, 7), (10, 20, 30, 40, 5, 15), strict=True)
    ]
    write_csv(tmp_path / "train.csv", training)
    nothing = WALKED | {"eval_waypoints_per_episode": 1.0}
    rows = [nothing | {"iteration": 2}, WALKED | {"iteration": 4}, GAITED | {"iteration": 6}]
    write_csv(tmp_path / "eval.csv", [{"iteration": r.pop("iteration"), **r} for r in rows])
    return tmp_path


def test_time_to_goals_reads_the_first_evaluation_that_meets_each(run: Path) -> None:
    reached = time_to_goals(run)
    assert reached["walking"] == {"iteration": 4, "env_steps": 4000.0, "wall_seconds": 40.0}
    for goal in ("flying", "switching", "gait"):
        assert reached[goal] == {"iteration": 6, "env_steps": 6000.0, "wall_seconds": 55.0}


def test_the_benchmark_prints_the_table(run: Path) -> None:
    script = ROOT / "benchmarks" / "bench_time_to_goal.py"
    result = subprocess.run(
        [sys.executable, str(script), str(run)], capture_output=True, text=True, check=True
    )
    line = next(x for x in result.stdout.splitlines() if x.startswith(run.name))
    assert "4: 0.0 M, 0.01 h" in line and line.count("6: 0.0 M, 0.02 h") == 3
    missing = subprocess.run(
        [sys.executable, str(script), str(run / "nothing")], capture_output=True, text=True
    )
    assert missing.returncode == 2 and "no eval.csv" in missing.stderr
