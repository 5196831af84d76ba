"""Runs of the trajectory optimisation: one scenario solved, checked and written for a robot, a
batch of them (a grid of targets, a flight library) in worker processes, and their summaries.
Importable without the [trajopt] extra; a run without it is a TrajoptError naming it."""

from __future__ import annotations

import contextlib
import os
from collections.abc import Callable, Iterable, Iterator
from dataclasses import replace
from pathlib import Path
from typing import Any

from motionkit.errors import MotionkitError, TrajoptError
from motionkit.extras import require
from motionkit.outputs import check_out, claim_out, claimed_out
from motionkit.robot import Robot
from motionkit.trajopt.config import TrajoptConfig
from motionkit.workers import worker_pool

Task = tuple[dict[str, Any], str, str, bool, Robot]  # config, out folder, clip name, replay, robot
Outcome = tuple[str, bool, str, dict[str, float]]  # name, solved, summary or error, figures
FIGURES = ("solve_s", "duration_s", "airborne_s")  # what a batch reports of each clip
THREAD_VARIABLES = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")
SUFFIXES = (".mcap", ".knots.npz", ".config.json")  # the files of one solve


def clip_files(names: Iterable[str]) -> list[str]:
    """The files the solves `names` write."""
    return [f"{name}{suffix}" for name in names for suffix in SUFFIXES]


def check_clips(out: Path, names: Iterable[str]) -> None:
    """Refuse up front an --out that cannot take these solves (a file, read only, or holding
    files of their names that motionkit did not write), or a name that leads outside it."""
    check_out(Path(out), clip_files(names), TrajoptError)


def clip_stem(config: TrajoptConfig) -> str:
    """The default file stem of a solve: its scenario and target ("takeoff_+0p00_+0p00_+1p00")."""
    x, y, z = config.scenario.target
    return f"{config.scenario.name}_{x:+.2f}_{y:+.2f}_{z:+.2f}".replace(".", "p")


def solve_clip(
    config: TrajoptConfig,
    out: Path,
    name: str,
    robot: Robot,
    replay: bool = True,
    log: Callable[[str], None] | None = None,
) -> dict[str, Any]:
    """Solve, check and write one scenario for `robot` as OUT/NAME.mcap (+ .knots.npz,
    .config.json); returns its metrics. TrajoptError (nothing written) when it fails."""
    require("trajopt", "trajopt", TrajoptError)
    check_clips(out, [name])
    from motionkit.trajopt.checks import check_solution, motion_figures, solver_figures
    from motionkit.trajopt.output import write_outputs
    from motionkit.trajopt.solve import solve

    log = log or (lambda line: print(f"[{name}] {line}", flush=True))
    solution = solve(robot, config, log=log)
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
    folder = claim_out(Path(out), clip_files([name]), TrajoptError)
    write_outputs(folder, name, solution, robot, metrics)
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


def solve_grid(
    config: TrajoptConfig,
    targets: Iterable[tuple[float, float, float]],
    out: Path,
    robot: Robot,
    jobs: int,
    replay: bool = True,
) -> list[Outcome]:
    """One solve of `config` per target, each clip named by `clip_stem`, in `jobs` processes."""
    tasks = []
    for target in targets:
        item = config.with_scenario(target=tuple(target))
        tasks.append((item.to_dict(), str(out), clip_stem(item), replay, robot))
    return solve_batch(tasks, [config], jobs)


def solve_library(
    path: Path, out: Path, robot: Robot, jobs: int, replay: bool = True, quiet: bool = False
) -> list[Outcome]:
    """Solve, check and write every clip of a flight library for `robot` in `jobs` processes;
    a clip that fails is reported in its outcome and writes nothing."""
    from motionkit.trajopt.library import read_library

    solves = read_library(path)
    configs = [solve.config for solve in solves]
    if quiet:  # IPOPT is quiet already unless an entry asks for its log
        configs = [replace(c, solver=replace(c.solver, print_level=0)) for c in configs]
    tasks = [
        (config.to_dict(), str(out), solve.name, replay, robot)
        for solve, config in zip(solves, configs, strict=True)
    ]
    print(f"{path}: {len(tasks)} clips from {len({s.entry for s in solves})} entries", flush=True)
    return solve_batch(tasks, configs, jobs)


def solve_batch(tasks: list[Task], configs: list[TrajoptConfig], jobs: int) -> list[Outcome]:
    """Solve the tasks in `jobs` worker processes, printing each outcome as it comes; with
    several workers, the compiled derivatives of each distinct jet model in `configs` are built
    here first, once, so that the workers find them cached."""
    require("trajopt", "trajopt", TrajoptError)
    if not tasks:
        return []
    out = Path(tasks[0][1])
    check_clips(out, [task[2] for task in tasks])  # before any work
    if len(tasks) > 1 and jobs > 1:
        robot = tasks[0][4]
        for config in {c.jets: c for c in configs}.values():
            _compile_once(config, robot)
    outcomes = []
    with (
        claimed_out(out, clip_files(task[2] for task in tasks), TrajoptError),
        _single_threaded_workers(),
        worker_pool(jobs, out) as pool,
    ):
        for outcome in pool.map(_batch_task, tasks):
            name, ok, text, _ = outcome
            print(text if ok else f"{name}: FAILED: {text}", flush=True)
            outcomes.append(outcome)
    return outcomes


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


def _batch_task(task: Task) -> Outcome:
    data, out, name, replay, robot = task
    try:
        metrics = solve_clip(TrajoptConfig.from_dict(data), Path(out), name, robot, replay)
    except MotionkitError as exc:
        return name, False, str(exc), {}
    return name, True, summary_line(name, metrics), {k: metrics[k] for k in FIGURES}


def _compile_once(config: TrajoptConfig, robot: Robot) -> None:
    """Build the compiled functions in this process, so that the workers find them cached."""
    from motionkit.trajopt.solve import Prepared

    Prepared(robot, config, log=lambda text: print(text, flush=True))


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
