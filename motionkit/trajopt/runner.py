"""Runs of the trajectory optimisation: one scenario solved, checked and written for a robot, a
batch of them (a grid of targets, a flight library) in worker processes, and their summaries.
Importable without the [trajopt] extra; a run without it is a TrajoptError naming it."""

from __future__ import annotations

import contextlib
import json
import os
from collections.abc import Callable, Iterable, Iterator
from dataclasses import replace
from pathlib import Path
from typing import Any

from motionkit.digests import code_digest, digest, versions
from motionkit.errors import MotionkitError, TrajoptError
from motionkit.executors import THREAD_VARIABLES, open_executor
from motionkit.extras import require
from motionkit.outputs import check_out, claim_out, claimed_out, up_to_date, write_files
from motionkit.robot import Robot
from motionkit.trajopt.config import TrajoptConfig

Task = tuple[dict[str, Any], str, bool, Robot]  # config, clip name, replay, robot
Outcome = tuple[str, bool, str, dict[str, float]]  # name, solved, summary or error, figures
FIGURES = ("solve_s", "duration_s", "airborne_s")  # what a batch reports of each clip
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
    metrics, files = solve_files(config, name, robot, replay, log)
    folder = claim_out(Path(out), clip_files([name]), TrajoptError)
    write_files(folder, files)
    return metrics


def solve_files(
    config: TrajoptConfig,
    name: str,
    robot: Robot,
    replay: bool = True,
    log: Callable[[str], None] | None = None,
) -> tuple[dict[str, Any], dict[str, bytes]]:
    """Solve and check one scenario: its metrics and its files (name -> bytes, in the order
    they are to be written); TrajoptError when it fails."""
    from motionkit.trajopt.checks import check_solution, motion_figures, solver_figures
    from motionkit.trajopt.output import encode_outputs
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
    return metrics, encode_outputs(name, solution, robot, metrics)


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
    cluster: str | None = None,
    resume: bool = False,
) -> list[Outcome]:
    """One solve of `config` per target, each clip named by `clip_stem`, in `jobs` processes
    (or on the Ray cluster at `cluster`); `resume` keeps the clips that are up to date."""
    tasks = []
    for target in targets:
        item = config.with_scenario(target=tuple(target))
        tasks.append((item.to_dict(), clip_stem(item), replay, robot))
    return solve_batch(tasks, [config], out, jobs, cluster, resume)


def solve_library(
    path: Path,
    out: Path,
    robot: Robot,
    jobs: int,
    replay: bool = True,
    quiet: bool = False,
    cluster: str | None = None,
    resume: bool = False,
) -> list[Outcome]:
    """Solve, check and write every clip of a flight library for `robot` in `jobs` processes
    (or on the Ray cluster at `cluster`); a clip that fails is reported in its outcome and
    writes nothing; `resume` keeps the clips that are up to date."""
    from motionkit.trajopt.library import read_library

    solves = read_library(path)
    configs = [solve.config for solve in solves]
    if quiet:  # IPOPT is quiet already unless an entry asks for its log
        configs = [replace(c, solver=replace(c.solver, print_level=0)) for c in configs]
    tasks = [
        (config.to_dict(), solve.name, replay, robot)
        for solve, config in zip(solves, configs, strict=True)
    ]
    print(f"{path}: {len(tasks)} clips from {len({s.entry for s in solves})} entries", flush=True)
    return solve_batch(tasks, configs, out, jobs, cluster, resume)


def solve_batch(
    tasks: list[Task],
    configs: list[TrajoptConfig],
    out: Path,
    jobs: int,
    cluster: str | None = None,
    resume: bool = False,
) -> list[Outcome]:
    """Solve the tasks in `jobs` worker processes (or on the Ray cluster at `cluster`),
    printing each outcome as it comes; the workers return the files and this process writes
    them. With several workers, the compiled derivatives of each distinct jet model in
    `configs` are built here first, once, and handed to the workers (whose caches may be on
    other machines). With `resume`, a clip whose files are up to date (`task_key`) is kept."""
    require("trajopt", "trajopt", TrajoptError)
    if not tasks:
        return []
    out = Path(out)
    check_clips(out, [task[1] for task in tasks])  # before any work
    keys = [task_key(task) for task in tasks]
    outcomes: dict[int, Outcome] = {}
    with (
        _single_threaded_workers(),
        open_executor(jobs, cluster, TrajoptError) as executor,
        claimed_out(out, clip_files(task[1] for task in tasks), TrajoptError),
    ):
        for i, task in enumerate(tasks):
            kept = _kept(out, task[1], keys[i]) if resume else None
            if kept is not None:
                outcomes[i] = kept
                print(kept[2], flush=True)
        todo = [i for i in range(len(tasks)) if i not in outcomes]
        kept = f"; {len(outcomes)} up to date, kept" if outcomes else ""
        print(f"solving {len(todo)} clip(s) with {executor.where}{kept}", flush=True)
        shared: dict[str, bytes] = {}
        if todo and (cluster or (len(todo) > 1 and executor.workers > 1)):
            shared = _compile_once(configs, tasks[0][3])
        names = [tasks[i][1] for i in todo]
        for done in executor.run(_batch_task, [tasks[i] for i in todo], names, shared):
            i = todo[done.index]
            if done.value is None:
                outcome: Outcome = (tasks[i][1], False, done.lost, {})
            else:
                outcome, files = done.value
                if files:
                    write_files(out, files, keys[i])
            name, ok, text, _ = outcome
            print(text if ok else f"{name}: FAILED: {text}", flush=True)
            outcomes[i] = outcome
    return [outcomes[i] for i in range(len(tasks))]


def task_key(task: Task) -> str:
    """The hash of everything a solve's files depend on (its config, name, replay, the robot,
    the code and the solver's libraries): files recorded with it are up to date."""
    data, name, replay, robot = task
    return digest(
        "trajopt clip",
        name,
        data,
        replay,
        robot.model_hash,
        code_digest(__name__),
        versions("casadi", "adam-robotics", "mujoco"),
    )


def _kept(out: Path, name: str, key: str) -> Outcome | None:
    """The outcome of a solve whose files in `out` are up to date (from its .config.json)."""
    if not up_to_date(out, clip_files([name]), key):
        return None
    try:
        metrics = json.loads((out / f"{name}.config.json").read_text())["metrics"]
        text = summary_line(name, metrics)
        figures = {k: float(metrics[k]) for k in FIGURES}
    except (OSError, ValueError, KeyError, TypeError):
        return None  # unreadable: solved again
    return name, True, f"{text} (up to date, kept)", figures


def library_summary(
    outcomes: list[Outcome], wall: float, jobs: int, cluster: str | None = None
) -> str:
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
        + (f"on --cluster {cluster}" if cluster else f"with --jobs {jobs}")
    )
    if failed:
        lines.append(f"failed: {', '.join(failed)}")
    return "\n".join(lines)


def _batch_task(task: Task, libraries: dict[str, bytes]) -> tuple[Outcome, dict[str, bytes]]:
    """One solve in a worker: its outcome and its files (none when it failed)."""
    from motionkit.trajopt.compiled import install_libraries

    install_libraries(libraries)
    data, name, replay, robot = task
    try:
        metrics, files = solve_files(TrajoptConfig.from_dict(data), name, robot, replay)
    except MotionkitError as exc:
        return (name, False, str(exc), {}), {}
    return (name, True, summary_line(name, metrics), {k: metrics[k] for k in FIGURES}), files


def _compile_once(configs: list[TrajoptConfig], robot: Robot) -> dict[str, bytes]:
    """Build the compiled functions of each distinct jet model in `configs` here, once; their
    files, for the workers to install in their caches."""
    from motionkit.trajopt.compiled import LOADED, export_libraries
    from motionkit.trajopt.solve import Prepared

    first = len(LOADED)
    for config in {c.jets: c for c in configs}.values():
        Prepared(robot, config, log=lambda text: print(text, flush=True))
    return export_libraries(LOADED[first:])


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
