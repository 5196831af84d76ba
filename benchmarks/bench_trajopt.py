"""Trajectory optimisation: the walk-to-fly problem (trajopt/walk_to_fly.toml) with N knots;
with --library, the margin of every clip of a flight library to IPOPT's iteration limit.

    OMP_NUM_THREADS=1 python benchmarks/bench_trajopt.py [--knots 100] [--baseline NAME]
        [--repeat 3]
    OMP_NUM_THREADS=1 python benchmarks/bench_trajopt.py --library library [--jobs 1]
        [--only jump,takeoff_high] [--out DIR]

--library solves each clip as `motionkit trajopt --library` does (checks and both MuJoCo replays;
nothing kept unless --out) and prints a Markdown table, the one in docs/trajopt.md: per clip the
IPOPT iterations of each homotopy step, the largest against the limit of a step (`max_iter`),
the retries, IPOPT's seconds and the replays' largest base errors; then the CPU it ran on.
Target: every step below half its limit, no retry.

Target (2-core dev machine): N = 100 solved to IPOPT's tolerance in <= 60 s. For
reference the published solver took about 27.5 min (HSL ma97, limited-memory Hessian). The
baseline in the same run is the same problem with a limited-memory Hessian, without the warm
start of the complementarity homotopy, or with the derivatives left uncompiled. The first run on
a machine also compiles the derivatives to C (1-2 min, cached; in "build"). Prints problem size,
iterations, wall time and residuals of each. The recipe takes the default homotopy (eps 1e-2 ->
1e-6 in steps of 10x) and sets IPOPT's 'loqo' barrier oracle for the cold first step (the recipe
gives the reasons): 276 IPOPT iterations (155 + 5 + 32 + 37 + 47) since the boundary conditions
are imposed once (motionkit/trajopt/scenarios.py). The figures that follow are of the earlier
formulation, whose boundary conditions were partly imposed twice: the cold step also takes the
monotone mode's mu from the quality function (fixed_mu_oracle): 196 IPOPT iterations (68 + 26 +
20 + 65 + 17, eps 1e-2, 1e-4, 2e-5, 4e-6, 1e-6), 232 (107 + 28 + 25 + 55 + 17) without that, 295
with 1e-2, 1e-4, 1e-5, 1e-6 and 645 with 1e-2, 1e-6 and the default oracle.
Tried and left out (measured): a coarse solve at 50 knots interpolated as the guess
(the cold 100-knot solve from it took 295 iterations for eps 1e-4 alone; warm with interpolated
multipliers, over 500), a monotone or 'loqo' barrier, or a 10x complementarity weight in the
last step (500+, 479, 477 iterations instead of 313), a complementarity weight 100 or 1000
throughout (295 iterations; the cold step failed at 500), IPOPT's perturb_dec_fact 0.6 / 0.1
(cold step 191 / failed), MUMPS pivtol 1e-8 with no scaling (237 iterations; per-iteration time
within this machine's +-20 % noise), friction-pyramid edge magnitudes as bounded variables
instead of the 3,200 pyramid rows (cold step failed at 500 iterations, 0.3 s each), skipping
IPOPT's unregularised trial factorization in the cold step (a free dummy variable makes IPOPT
treat the Hessian as degenerate: linear solve 0.28 -> 0.17 s an iteration, but 344 cold
iterations), mu_target 1e-4 or 1e-3 in the cold step (500+), tol 1e-4 on the intermediate steps
(175 warm iterations instead of 125). Also dropped: the quality-function fixed_mu_oracle in the
warm steps too (203 iterations instead of 196); and, measured before it, the 'loqo' oracle in
the warm steps too (346 instead of 232), OpenBLAS on two threads (242, no faster),
mumps_mem_percent 100 (same path, no gain beyond noise). IPOPT's timing statistics: ~80 % of an
iteration is the linear solve (MUMPS; in most of the cold step IPOPT refactors to correct the
inertia), ~15 % function evaluations (on two threads).
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import tempfile
import time
from dataclasses import replace
from pathlib import Path
from typing import Any

from motionkit import recipes
from motionkit.core.errors import TrajoptError
from motionkit.robot.model import ironcub
from motionkit.trajopt.checks import check_solution
from motionkit.trajopt.config import TrajoptConfig
from motionkit.trajopt.kinematics import RobotKinematics
from motionkit.trajopt.runner import library_tasks, solve_batch
from motionkit.trajopt.solve import Prepared

RECIPE = recipes.find("trajopt", "walk_to_fly")


def run(label: str, config: TrajoptConfig, kinematics: RobotKinematics) -> float | None:
    """Solve once and print the figures; the wall time [s], or None when it failed."""
    robot = kinematics.robot
    start = time.perf_counter()
    prepared = Prepared(robot, config, kinematics)
    try:
        solution = prepared.solve()
    except TrajoptError as exc:
        wall = time.perf_counter() - start
        print(f"{label:<24} FAILED after {wall:.1f} s: {exc}")
        return None
    wall = time.perf_counter() - start
    checks = check_solution(solution, robot)
    steps = ", ".join(f"eps {s.eps:g}: {s.iterations} it {s.seconds:.1f} s" for s in solution.steps)
    print(
        f"{label:<24} {solution.status}: {solution.variables} variables, "
        f"{solution.constraints} constraints, {solution.iterations} iterations, "
        f"wall {wall:.1f} s (build {solution.build_seconds:.1f} s, solve "
        f"{solution.solve_seconds:.1f} s) [{steps}]"
    )
    print(
        f"{'':<24} residuals: dynamics {checks['residual_dynamics']:.2g}, kinematic ties "
        f"{checks['residual_kinematic_ties']:.2g}, complementarity "
        f"{checks['complementarity_violation_nm']:.2g} N m, target error "
        f"{checks['target_error_m'] * 1000:.2f} mm, checks passed: {checks['passed']}"
    )
    return wall


def cpu_model() -> str:
    """The CPU's model name (as `lscpu` says it), or what the platform module knows."""
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


def margin_row(name: str, metrics: dict[str, Any]) -> str:
    """One clip's row of the table: its steps' iterations, the largest against the limit, the
    retries, IPOPT seconds and the replays' largest base errors [m]."""
    steps = [int(step["iterations"]) for step in metrics["homotopy"]]
    largest, limit = max(steps), int(metrics["max_iter"])
    return (
        f"| {name} | {metrics['knots']} | {' + '.join(map(str, steps))} = {sum(steps)} | "
        f"{largest} / {limit} ({largest / limit:.0%}) | {metrics['retries']} | "
        f"{metrics['solve_s']:.1f} | {metrics['replay_base_error_max_m']:.2f} | "
        f"{metrics['stabilised_base_error_max_m']:.3f} |"
    )


def library_margins(library: str, jobs: int, only: list[str], out: Path | None) -> None:
    """Solve the library's clips (those whose names hold one of `only`, if given) and print
    the table of their margins to the iteration limit."""
    robot = ironcub()
    tasks, configs = library_tasks(recipes.find("trajopt", library), robot, True, True, print)
    chosen = [i for i, task in enumerate(tasks) if not only or any(s in task.name for s in only)]
    tasks, configs = [tasks[i] for i in chosen], [configs[i] for i in chosen]
    with tempfile.TemporaryDirectory() as scratch:
        folder = out or Path(scratch)
        start = time.perf_counter()
        outcomes = solve_batch(tasks, configs, folder, jobs, resume=False, progress=print)
        wall = time.perf_counter() - start
        rows, shares = [], []
        for outcome in outcomes:
            if not outcome.solved:
                rows.append(f"| {outcome.name} | FAILED: {outcome.text} |")
                continue
            path = folder / f"{outcome.name}.config.json"
            metrics = json.loads(path.read_text())["metrics"]
            rows.append(margin_row(outcome.name, metrics))
            steps = [int(step["iterations"]) for step in metrics["homotopy"]]
            shares.append(max(steps) / int(metrics["max_iter"]))
    print(
        "\n| clip | knots | IPOPT iterations per step = in all | largest step / limit | "
        "retries | IPOPT [s] | base error open loop [m] | stabilised [m] |"
    )
    print("|---|---:|---|---|---:|---:|---:|---:|")
    print("\n".join(rows))
    solved = sum(o.solved for o in outcomes)
    print(
        f"\n{solved} of {len(outcomes)} clips solved and passed; the largest step at "
        f"{max(shares, default=0):.0%} of its limit; wall {wall:.0f} s with --jobs {jobs}; "
        f"CPU: {cpu_model()}"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--knots", type=int, default=100)
    parser.add_argument(
        "--baseline",
        choices=("limited-memory", "no-warm-start", "uncompiled", "none"),
        default="no-warm-start",
    )
    parser.add_argument("--max-iter", type=int, default=1000)
    parser.add_argument(
        "--repeat",
        type=int,
        default=1,
        help="solve the main problem this many times and print the median wall time (this "
        "machine's speed varies by ~20 %% from run to run)",
    )
    parser.add_argument("--library", help="a flight library (built-in: library): its margins")
    parser.add_argument("--jobs", type=int, default=1, help="processes for --library")
    parser.add_argument("--only", default="", help="--library: clips whose names hold one of "
                        "these comma-separated parts")  # fmt: skip
    parser.add_argument("--out", type=Path, help="--library: keep the clips in this folder")
    args = parser.parse_args()
    if args.library:
        library_margins(args.library, args.jobs, [s for s in args.only.split(",") if s], args.out)
        return

    config = TrajoptConfig.from_toml(RECIPE).with_scenario(knots=args.knots)
    config = replace(config, solver=replace(config.solver, print_level=0, max_iter=args.max_iter))
    kinematics = RobotKinematics(ironcub())
    print(f"walk-to-fly, N = {args.knots} knots (target <= 60 s; published: ~27.5 min)")
    walls = [run("exact Hessian, warm", config, kinematics) for _ in range(args.repeat)]
    if args.repeat > 1:
        solved = sorted(wall for wall in walls if wall is not None)
        figures = ", ".join(f"{wall:.1f}" for wall in solved)
        median = f"median {statistics.median(solved):.1f} s" if solved else "none solved"
        print(f"{'':<24} {len(solved)} of {args.repeat} solved, wall [s]: {figures}; {median}")
    baselines = {
        "limited-memory": ("limited-memory Hessian", {"hessian": "limited-memory"}),
        "no-warm-start": ("no warm start", {"warm_start": False}),
    }
    if args.baseline == "uncompiled":  # derivatives in CasADi's virtual machine, as before
        os.environ["MOTIONKIT_TRAJOPT_COMPILE"] = "0"
        run("uncompiled derivatives", config, kinematics)
    if args.baseline in baselines:
        label, change = baselines[args.baseline]
        run(label, replace(config, solver=replace(config.solver, **change)), kinematics)


if __name__ == "__main__":
    main()
