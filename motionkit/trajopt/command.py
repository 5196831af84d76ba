"""`motionkit trajopt`: solve a flight scenario (or a grid of targets) and write MCAP clips."""

from __future__ import annotations

import argparse
import contextlib
import itertools
import multiprocessing
import os
import sys
import time as clock
from collections.abc import Iterator
from concurrent.futures import ProcessPoolExecutor
from dataclasses import replace
from pathlib import Path
from typing import Any

from motionkit.errors import MotionkitError, TrajoptError
from motionkit.extras import require
from motionkit.recipes import argument
from motionkit.trajopt.config import SCENARIOS, TrajoptConfig

EPILOG = """\
Built-in recipes for every scenario: `motionkit recipes trajopt`. Targets are world positions [m] of
the centre of mass; the robot starts at the origin facing -x (iRonCub's root link x axis points
backwards). Each solution is checked (residuals, complementarity, target within 1 cm, thrust limits,
MuJoCo replay open loop and stabilised by base feedback through the jets, which must track the plan
within [replay] max_base_error); a request that cannot be solved exits with status 1 and writes
nothing. --library FILE solves every clip a flight library names (the built-in one: --library
library)."""


def add_commands(stages: argparse._SubParsersAction) -> None:
    parser = stages.add_parser(
        "trajopt",
        help="flight motions by trajectory optimisation (CasADi + IPOPT)",
        description="Solve a take-off, walk-to-fly, flight, landing or jump scenario and write "
        "it as an MCAP clip, the knots (.knots.npz) and the resolved config (.config.json).",
        epilog=EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("--scenario", choices=SCENARIOS, help="required unless --library")
    parser.add_argument(
        "--library", type=argument("trajopt"), help="a TOML naming many solves (built-in: library)"
    )
    parser.add_argument(
        "--config",
        type=argument("trajopt"),
        help="recipe: a TOML file or a built-in name (default: defaults)",
    )
    parser.add_argument("--out", type=Path, required=True, help="output folder")
    parser.add_argument("--name", help="file name stem (default: the scenario and target)")
    parser.add_argument("--target", type=float, nargs=3, metavar=("X", "Y", "Z"))
    parser.add_argument("--height", type=float, help="target CoM height [m] (sets target z)")
    parser.add_argument("--start", type=float, nargs=3, metavar=("X", "Y", "Z"),
                        help="hover start CoM position [m]")  # fmt: skip
    parser.add_argument("--knots", type=int)
    parser.add_argument("--quiet", action="store_true", help="hide IPOPT's iteration log")
    parser.add_argument("--no-replay", action="store_true", help="skip the MuJoCo replays")
    parser.add_argument(
        "--grid",
        nargs=3,
        metavar=("XS", "YS", "ZS"),
        help="batch mode: comma-separated target values per axis (e.g. -1,0 0 1,1.5)",
    )
    parser.add_argument("--jobs", type=int, default=os.cpu_count() or 1,
                        help="parallel processes for --grid and --library")  # fmt: skip
    parser.set_defaults(handler=_run)


def _config(args: argparse.Namespace) -> TrajoptConfig:
    config = TrajoptConfig.from_toml(args.config) if args.config else TrajoptConfig()
    changes: dict[str, Any] = {"name": args.scenario}
    if args.target is not None:
        changes["target"] = tuple(args.target)
    if args.height is not None:
        target = changes.get("target", config.scenario.target)
        changes["target"] = (target[0], target[1], args.height)
    if args.start is not None:
        changes["start_position"] = tuple(args.start)
    if args.knots is not None:
        changes["knots"] = args.knots
    if args.quiet:
        config = replace(config, solver=replace(config.solver, print_level=0))
    return config.with_scenario(**changes)


def _stem(config: TrajoptConfig) -> str:
    x, y, z = config.scenario.target
    return f"{config.scenario.name}_{x:+.2f}_{y:+.2f}_{z:+.2f}".replace(".", "p")


def run_one(config: TrajoptConfig, out: Path, name: str, replay: bool = True) -> dict[str, Any]:
    """Solve, check and write one scenario; raise TrajoptError (nothing written) on failure."""
    from motionkit.robot.model import ironcub
    from motionkit.trajopt.checks import check_solution, motion_figures, solver_figures
    from motionkit.trajopt.output import write_outputs
    from motionkit.trajopt.solve import solve

    robot = ironcub()
    solution = solve(robot, config, log=lambda line: print(f"[{name}] {line}", flush=True))
    metrics = solver_figures(solution) | check_solution(solution, robot) | motion_figures(solution)
    if replay:
        from motionkit.trajopt.replay import replay as run_replay
        from motionkit.trajopt.replay import stabilised_replay

        metrics |= run_replay(solution, robot) | stabilised_replay(solution, robot)
        metrics["passed"] = metrics["passed"] and metrics["stabilised_tracked"]
    if not metrics["passed"]:
        raise TrajoptError(
            f"{name}: the solution fails its checks: "
            + ", ".join(f"{k} = {v}" for k, v in metrics.items() if not isinstance(v, list))
        )
    write_outputs(out, name, solution, robot, metrics)
    return metrics


def summary_line(name: str, metrics: dict[str, Any]) -> str:
    text = (
        f"{name}: {metrics['status']}, {metrics['iterations']} iterations, "
        f"{metrics['solve_s']:.1f} s (+{metrics['build_s']:.1f} s build); "
        f"{metrics['variables']} variables, {metrics['constraints']} constraints; "
        f"target error {metrics['target_error_m'] * 1000:.2f} mm, complementarity "
        f"{metrics['complementarity_violation_nm']:.2g} N m, dynamics residual "
        f"{metrics['residual_dynamics']:.2g}"
    )
    if "replay_base_error_max_m" in metrics:
        text += f"; replay base error max {metrics['replay_base_error_max_m']:.3f} m open loop"
    if "stabilised_base_error_max_m" in metrics:
        text += f", {metrics['stabilised_base_error_max_m']:.3f} m stabilised"
    return text


Task = tuple[dict[str, Any], str, str, bool]  # config, out folder, clip name, replay
Outcome = tuple[str, bool, str, dict[str, float]]  # name, solved, summary or error, figures
FIGURES = ("solve_s", "duration_s", "airborne_s")  # what a batch reports of each clip


def _batch_task(task: Task) -> Outcome:
    data, out, name, replay = task
    try:
        metrics = run_one(TrajoptConfig.from_dict(data), Path(out), name, replay)
    except MotionkitError as exc:
        return name, False, str(exc), {}
    return name, True, summary_line(name, metrics), {k: metrics[k] for k in FIGURES}


def _compile_once(config: TrajoptConfig) -> None:
    """Build the compiled functions in this process, so that the workers find them cached."""
    from motionkit.robot import ironcub
    from motionkit.trajopt.solve import Prepared

    Prepared(ironcub(), config, log=lambda text: print(text, flush=True))


def _run(args: argparse.Namespace) -> int | None:
    require("trajopt", "motionkit trajopt", TrajoptError)  # before solve.py imports casadi
    if args.library is not None:
        return _run_library(args)
    if args.scenario is None:
        raise TrajoptError("--scenario is required (or --library FILE)")
    config = _config(args)
    if args.grid is None:
        name = args.name or _stem(config)
        try:
            metrics = run_one(config, args.out, name, not args.no_replay)
        except TrajoptError as exc:
            print(f"motionkit: trajopt failed: {exc}", file=sys.stderr)
            return 1
        print(summary_line(name, metrics))
        print(f"wrote {args.out / name}.mcap (+ .knots.npz, .config.json)")
        return None
    try:
        axes = [[float(v) for v in axis.split(",")] for axis in args.grid]
    except ValueError as exc:
        raise TrajoptError(f"--grid: expected comma-separated numbers ({exc})") from exc
    tasks = []
    for target in itertools.product(*axes):
        item = config.with_scenario(target=tuple(target))
        tasks.append((item.to_dict(), str(args.out), _stem(item), not args.no_replay))
    outcomes = _run_batch(tasks, [config], args.jobs)
    failed = sum(not ok for _, ok, _, _ in outcomes)
    print(f"{len(tasks) - failed} of {len(tasks)} targets solved; clips in {args.out}")
    return 1 if failed else None


def _run_batch(tasks: list[Task], configs: list[TrajoptConfig], jobs: int) -> list[Outcome]:
    """Solve the tasks in `jobs` worker processes, printing each outcome as it comes; with
    several workers, the compiled derivatives of each distinct jet model in `configs` are built
    here first, once, so that the workers find them cached."""
    if len(tasks) > 1 and jobs > 1:
        for config in {c.jets: c for c in configs}.values():
            _compile_once(config)
    outcomes = []
    spawn = multiprocessing.get_context("spawn")  # no fork of a process that may hold threads
    with (
        _single_threaded_workers(),
        ProcessPoolExecutor(max_workers=max(1, jobs), mp_context=spawn) as pool,
    ):
        for outcome in pool.map(_batch_task, tasks):
            name, ok, text, _ = outcome
            print(text if ok else f"{name}: FAILED: {text}", flush=True)
            outcomes.append(outcome)
    return outcomes


THREAD_VARIABLES = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")


@contextlib.contextmanager
def _single_threaded_workers() -> Iterator[None]:
    """Workers spawned in this block run their BLAS on one thread (unless the user set it):
    one solve per core, and the same IPOPT iterations as a single-threaded solve. With
    threaded BLAS, near-degenerate solves of the library took other paths and some ran out of
    iterations."""
    saved = {name: os.environ.get(name) for name in THREAD_VARIABLES}
    for name in THREAD_VARIABLES:
        os.environ.setdefault(name, "1")
    try:
        yield
    finally:
        for name, value in saved.items():
            if value is None:
                os.environ.pop(name, None)
            else:
                os.environ[name] = value


LIBRARY_ONLY = ("scenario", "config", "name", "target", "height", "start", "knots", "grid")


def _run_library(args: argparse.Namespace) -> int | None:
    start = clock.perf_counter()
    clashing = [f"--{key}" for key in LIBRARY_ONLY if getattr(args, key) is not None]
    if clashing:
        raise TrajoptError(f"--library names its own scenarios and targets: drop {clashing}")
    outcomes = solve_library(args.library, args.out, args.jobs, not args.no_replay, args.quiet)
    print(library_summary(outcomes, clock.perf_counter() - start, args.jobs))
    print(f"clips in {args.out}")
    return 1 if any(not ok for _, ok, _, _ in outcomes) else None


def solve_library(
    path: Path, out: Path, jobs: int, replay: bool = True, quiet: bool = False
) -> list[Outcome]:
    """Solve, check and write every clip of a flight library in `jobs` processes; a clip that
    fails is reported in its outcome and writes nothing."""
    from motionkit.trajopt.library import read_library

    solves = read_library(path)
    configs = [solve.config for solve in solves]
    if quiet:  # IPOPT is quiet already unless an entry asks for its log
        configs = [replace(c, solver=replace(c.solver, print_level=0)) for c in configs]
    tasks = [
        (config.to_dict(), str(out), solve.name, replay)
        for solve, config in zip(solves, configs, strict=True)
    ]
    print(f"{path}: {len(tasks)} clips from {len({s.entry for s in solves})} entries", flush=True)
    return _run_batch(tasks, configs, jobs)


def library_summary(outcomes: list[Outcome], wall: float, jobs: int) -> str:
    """A table of the clips (airborne, duration and IPOPT seconds) and the totals."""
    solved = [(name, figures) for name, ok, _, figures in outcomes if ok]
    width = max([len(name) for name, _ in solved] + [4])
    lines = [f"{'clip':<{width}}  airborne [s]  duration [s]  solve [s]"]
    for name, f in solved:
        lines.append(
            f"{name:<{width}}  {f['airborne_s']:12.2f}  {f['duration_s']:12.2f}  "
            f"{f['solve_s']:9.1f}"
        )
    airborne = sum(f["airborne_s"] for _, f in solved)
    solve_s = sum(f["solve_s"] for _, f in solved)
    per_clip = airborne / len(solved) if solved else 0.0
    failed = [name for name, ok, _, _ in outcomes if not ok]
    lines.append(
        f"{len(solved)} of {len(outcomes)} clips solved; airborne {airborne:.1f} s in all "
        f"({per_clip:.2f} s per clip); IPOPT {solve_s:.0f} s in all; wall {wall:.0f} s "
        f"with --jobs {jobs}"
    )
    if failed:
        lines.append(f"failed: {', '.join(failed)}")
    return "\n".join(lines)
