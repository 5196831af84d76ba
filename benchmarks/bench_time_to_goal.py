"""Env-steps and wall time to the walking, flying, switching and gait goals, per training run,
from the run's own evaluations (eval.csv) and training log (train.csv); the goals are those of
`motionkit.train.goals` (its docstring lists their figures).

    python benchmarks/bench_time_to_goal.py RUN [RUN ...]

A run resumed over several sessions counts the wall time of every session (setup and
evaluations included). Prints one row per run: the evaluation, env-steps (millions) and hours
at which each goal was first met ('-' where none met it), and how far the run went; runs side
by side compare recipes or levers trained on the same machine.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from motionkit.train.curves import read_table
from motionkit.train.goals import GOALS, cumulative_wall_seconds, time_to_goals


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("runs", nargs="+", type=Path, help="run folders of motionkit train")
    args = parser.parse_args()
    header = ["run", *GOALS, "trained"]
    rows = [header]
    for run in args.runs:
        try:
            reached = time_to_goals(run)
        except FileNotFoundError as exc:
            print(f"bench_time_to_goal: {exc}", file=sys.stderr)
            return 2
        training = read_table(run / "train.csv")
        hours = cumulative_wall_seconds(training["wall_seconds"])[-1] / 3600
        trained = f"{training['env_steps'][-1] / 1e6:.1f} M, {hours:.2f} h"
        cells = [_cell(reached[name]) for name in GOALS]
        rows.append([run.name, *cells, trained])
    widths = [max(len(r[i]) for r in rows) for i in range(len(header))]
    for row in rows:
        print("  ".join(cell.ljust(width) for cell, width in zip(row, widths, strict=True)))
    print("each goal: the iteration of the first evaluation that met it, env-steps, wall hours")
    return 0


def _cell(reached: dict[str, float] | None) -> str:
    if reached is None:
        return "-"
    steps, hours = reached["env_steps"] / 1e6, reached["wall_seconds"] / 3600
    return f"{reached['iteration']:.0f}: {steps:.1f} M, {hours:.2f} h"


if __name__ == "__main__":
    sys.exit(main())
