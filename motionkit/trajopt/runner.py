"""Runs of the trajectory optimisation: one scenario solved, checked and written for a robot, a
batch of them (a grid of targets, a flight library) in worker processes, and their summaries.
Importable without the [trajopt] extra; a run without it is a TrajoptError naming it."""

from __future__ import annotations

import contextlib
import json
import os
import pickle
from collections.abc import Iterable, Iterator
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

from motionkit.core.errors import MotionkitError, TrajoptError
from motionkit.core.extras import require
from motionkit.files.digests import code_digest, digest, versions
from motionkit.files.outputs import check_out, claim_out, claimed_out, up_to_date, write_files
from motionkit.robot import Robot
from motionkit.runtime.executors import THREAD_VARIABLES, open_executor
from motionkit.runtime.progress import Progress, silent
from motionkit.trajopt.config import TrajoptConfig

FIGURES = ("solve_s", "duration_s", "airborne_s")  # what a batch reports of each clip
SUFFIXES = (".mcap", ".knots.npz", ".config.json")  # the files of one solve


def clip_files(names: Iterable[str]) -> list[str]:
    """The files the solves `names` write."""
    return [f"{name}{suffix}" for name in names for suffix in SUFFIXES]


@dataclass(frozen=True)
class Task:
    """One solve of a batch, as it travels to a worker."""

    config: dict[str, Any]  # TrajoptConfig.to_dict()
    name: str  # the clip's file stem
    replay: bool
    robot: Robot


@dataclass(frozen=True)
class Outcome:
    """What a batch reports of one solve."""

    name: str
    solved: bool
    text: str  # its summary line, or why it failed
    figures: dict[str, float]  # FIGURES of a solved clip


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
    *,
    progress: Progress = silent,
) -> dict[str, Any]:
    """Solve, check and write one scenario for `robot`; returns its metrics.

    The clip is written as OUT/NAME.mcap (+ .knots.npz, .config.json). TrajoptError (nothing
    written) when it fails. `progress` receives the solve's lines ("[NAME] homotopy ...").

    Args:
        config: the scenario, weights, contacts, jets and solver settings of the solve.
        out: the output folder (OUT).
        name: the clip's file stem (NAME).
        robot: the robot to solve for.
        replay: also replay the solution in MuJoCo, open loop and stabilised; the
            stabilised replay must track for the solve to pass.
        progress: called with each line of the solve.

    Returns:
        The metrics also written to NAME.config.json: the solver's figures (status,
        iterations, variables, constraints, build_s, solve_s, duration_s ...), the checks'
        (`check_solution`), airborne_s and horizontal_speed_mps, with `replay` the replays'
        base and orientation errors and stabilised_tracked, and `passed`.

    Raises:
        TrajoptError: the [trajopt] extra missing, an `out` that cannot take the clip (a file,
            read only, holding files of these names motionkit did not write) or a `name`
            leading outside it, a solve that fails or a solution that fails its checks.
    """
    require("trajopt", "trajopt", TrajoptError)
    check_clips(out, [name])
    metrics, files = solve_files(config, name, robot, replay, progress)
    folder = claim_out(Path(out), clip_files([name]), TrajoptError)
    write_files(folder, files)
    return metrics


def solve_files(
    config: TrajoptConfig,
    name: str,
    robot: Robot,
    replay: bool = True,
    progress: Progress = silent,
) -> tuple[dict[str, Any], dict[str, bytes]]:
    """Solve and check one scenario: its metrics and its files (name -> bytes, in the order
    they are to be written); TrajoptError when it fails."""
    from motionkit.trajopt.checks import check_solution, motion_figures, solver_figures
    from motionkit.trajopt.output import encode_outputs
    from motionkit.trajopt.solve import solve

    solution = solve(robot, config, log=lambda line: progress(f"[{name}] {line}"))
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
    """The one line `motionkit trajopt` prints of a solved clip.

    Status, iterations, solve and build seconds, problem size, target error [mm],
    complementarity [N m], dynamics residual and, when the metrics have them, the replays'
    largest base errors [m].

    Args:
        name: the clip's name, the line's start.
        metrics: the solve's metrics (those `solve_clip` returns).

    Returns:
        The line, without a newline.
    """
    text = (
        f"{name}: {metrics['status']}, {metrics['iterations']} iterations{_margin(metrics)}, "
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


def _margin(metrics: dict[str, Any]) -> str:
    """The margin to IPOPT's limit, " (at most N of MAX_ITER a step, R step(s) retried)",
    where the metrics have it (those of older clips may not)."""
    steps = metrics.get("homotopy")
    if not isinstance(steps, list) or "max_iter" not in metrics:
        return ""
    largest = max(int(step["iterations"]) for step in steps)
    retries = int(metrics.get("retries", 0))
    text = f" (at most {largest} of {metrics['max_iter']} a step"
    return text + (f", {retries} step(s) retried)" if retries else ")")


def solve_grid(
    config: TrajoptConfig,
    targets: Iterable[tuple[float, float, float]],
    out: Path,
    robot: Robot,
    jobs: int,
    replay: bool = True,
    cluster: str | None = None,
    resume: bool = True,
    *,
    progress: Progress = silent,
) -> list[Outcome]:
    """One solve of `config` per target, in `jobs` processes or on a Ray cluster.

    Each clip is named by `clip_stem` (scenario and target, "takeoff_+0p00_+0p00_+1p00"); a
    clip that fails is reported in its outcome and writes nothing.

    Args:
        config: the solve; each target replaces its scenario's target.
        targets: the scenario targets, each (x, y, z) [m] (a stand end: only x, y count).
        out: the output folder of the clips.
        robot: the robot to solve for.
        jobs: the number of local worker processes.
        replay: also replay each solution in MuJoCo (see `solve_clip`).
        cluster: the address of a Ray cluster to solve on instead (None: local processes).
        resume: keep the clips in `out` that are up to date instead of solving them again
            (False: solve every target again).
        progress: called with each line of progress and each outcome's line.

    Returns:
        One Outcome per target, in their order: name, solved, its summary line (or why it
        failed) and its figures (solve_s, duration_s, airborne_s).

    Raises:
        TrajoptError: a target that makes the config invalid (not finite), the [trajopt]
            extra missing, an `out` that cannot take the clips, or a `cluster` that cannot be
            reached (all before anything is written).
    """
    tasks = []
    for target in targets:
        item = config.with_scenario(target=tuple(target))
        tasks.append(Task(item.to_dict(), clip_stem(item), replay, robot))
    return solve_batch(tasks, [config], out, jobs, cluster, resume, progress=progress)


def solve_library(
    path: Path,
    out: Path,
    robot: Robot,
    jobs: int,
    replay: bool = True,
    quiet: bool = False,
    cluster: str | None = None,
    resume: bool = True,
    *,
    progress: Progress = silent,
) -> list[Outcome]:
    """Solve, check and write every clip of a flight library for `robot`.

    The solves run in `jobs` processes (or on the Ray cluster at `cluster`); each clip is
    written as soon as it is solved, a clip that fails is reported in its outcome and writes
    nothing, and a rerun (`resume`) keeps the clips that are up to date: after a failure or an
    interrupt, only the missing clips are solved.

    Args:
        path: the library's TOML file (see `read_library`).
        out: the output folder of the clips.
        robot: the robot to solve for.
        jobs: the number of local worker processes.
        replay: also replay each solution in MuJoCo (see `solve_clip`).
        quiet: silence IPOPT (print_level 0) even where an entry asks for its log.
        cluster: the address of a Ray cluster to solve on instead (None: local processes).
        resume: keep the clips in `out` that are up to date instead of solving them again
            (False: solve every clip again).
        progress: called with each line of progress and each outcome's line.

    Returns:
        One Outcome per clip of the library, in its order (see `solve_grid`).

    Raises:
        TrajoptError: a library that cannot be read or is invalid, the [trajopt] extra
            missing, an `out` that cannot take the clips, or a `cluster` that cannot be
            reached (all before anything is written).
    """
    tasks, configs = library_tasks(path, robot, replay, quiet, progress)
    return solve_batch(tasks, configs, out, jobs, cluster, resume, progress=progress)


def library_tasks(
    path: Path, robot: Robot, replay: bool, quiet: bool, progress: Progress = silent
) -> tuple[list[Task], list[TrajoptConfig]]:
    """The solves of a flight library as batch tasks, and their configs (IPOPT silenced when
    `quiet`); TrajoptError when the library cannot be read or is invalid."""
    from motionkit.trajopt.library import read_library

    solves = read_library(path)
    configs = [solve.config for solve in solves]
    if quiet:  # IPOPT is quiet already unless an entry asks for its log
        configs = [replace(c, solver=replace(c.solver, print_level=0)) for c in configs]
    tasks = [
        Task(config.to_dict(), solve.name, replay, robot)
        for solve, config in zip(solves, configs, strict=True)
    ]
    progress(f"{path}: {len(tasks)} clips from {len({s.entry for s in solves})} entries")
    return tasks, configs


def solve_batch(
    tasks: list[Task],
    configs: list[TrajoptConfig],
    out: Path,
    jobs: int,
    cluster: str | None = None,
    resume: bool = False,
    *,
    progress: Progress = silent,
) -> list[Outcome]:
    """Solve the tasks in `jobs` worker processes (or on the Ray cluster at `cluster`),
    reporting each outcome to `progress` as it comes (and, from the workers, the solves' lines
    when `progress` can be pickled: a module-level function); the workers return the files and
    this process writes them, each clip as soon as it is solved (atomically, its key recorded
    last), so that an interrupted or failed batch keeps every clip solved. With several
    workers, the compiled derivatives of each distinct jet model in `configs` are built here
    first, once, and handed to the workers (whose caches may be on other machines). With
    `resume`, a clip whose files are up to date (`task_key`) is kept."""
    require("trajopt", "trajopt", TrajoptError)
    if not tasks:
        return []
    out = Path(out)
    names = [task.name for task in tasks]
    check_clips(out, names)  # before any work
    keys = [task_key(task) for task in tasks]
    outcomes: dict[int, Outcome] = {}
    with (
        _single_threaded_workers(),
        open_executor(jobs, cluster, TrajoptError) as executor,
        claimed_out(out, clip_files(names), TrajoptError),
    ):
        for i, task in enumerate(tasks):
            kept = _kept(out, task.name, keys[i]) if resume else None
            if kept is not None:
                outcomes[i] = kept
                progress(kept.text)
        todo = [i for i in range(len(tasks)) if i not in outcomes]
        note = f"; {len(outcomes)} up to date, kept" if outcomes else ""
        progress(f"solving {len(todo)} clip(s) with {executor.where}{note}")
        libraries: dict[str, bytes] = {}
        if todo and (cluster or (len(todo) > 1 and executor.workers > 1)):
            libraries = _compile_once(configs, tasks[0].robot, progress)
        items, shared = [tasks[i] for i in todo], (libraries, _portable(progress))
        for done in executor.run(_batch_task, items, [names[i] for i in todo], shared):
            i = todo[done.index]
            if done.value is None:
                outcome = Outcome(tasks[i].name, False, done.lost, {})
            else:
                outcome, files = done.value
                if files:
                    write_files(out, files, keys[i])
            progress(outcome.text if outcome.solved else f"{outcome.name}: FAILED: {outcome.text}")
            outcomes[i] = outcome
    return [outcomes[i] for i in range(len(tasks))]


def task_key(task: Task) -> str:
    """The hash of everything a solve's files depend on (its config, name, replay, the robot,
    the code and the solver's libraries): files recorded with it are up to date."""
    return digest(
        "trajopt clip",
        task.name,
        task.config,
        task.replay,
        task.robot.model_hash,
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
    return Outcome(name, True, f"{text} (up to date, kept)", figures)


def library_summary(
    outcomes: list[Outcome], wall: float, jobs: int, cluster: str | None = None
) -> str:
    """A table of the clips (airborne, duration and IPOPT seconds) and the totals.

    Args:
        outcomes: the outcomes of a batch (`solve_grid`, `solve_library`).
        wall: the batch's wall-clock time [s].
        jobs: the number of worker processes it ran in (named unless `cluster`).
        cluster: the Ray cluster it ran on (None: local processes).

    Returns:
        The lines: one per solved clip, the totals, and the failed clips' names if any.
    """
    solved = [o for o in outcomes if o.solved]
    width = max([len(o.name) for o in solved] + [4])
    lines = [f"{'clip':<{width}}  airborne [s]  duration [s]  solve [s]"]
    for o in solved:
        f = o.figures
        lines.append(
            f"{o.name:<{width}}  {f['airborne_s']:12.2f}  {f['duration_s']:12.2f}  "
            f"{f['solve_s']:9.1f}"
        )
    airborne = sum(o.figures["airborne_s"] for o in solved)
    solve_s = sum(o.figures["solve_s"] for o in solved)
    per_clip = airborne / len(solved) if solved else 0.0
    failed = [o.name for o in outcomes if not o.solved]
    lines.append(
        f"{len(solved)} of {len(outcomes)} clips solved; airborne {airborne:.1f} s in all "
        f"({per_clip:.2f} s per clip); IPOPT {solve_s:.0f} s in all; wall {wall:.0f} s "
        + (f"on --cluster {cluster}" if cluster else f"with --jobs {jobs}")
    )
    if failed:
        lines.append(
            f"failed: {', '.join(failed)} (the solved clips are kept: the same command again "
            "solves only what is missing)"
        )
    return "\n".join(lines)


def _batch_task(
    task: Task, shared: tuple[dict[str, bytes], Progress]
) -> tuple[Outcome, dict[str, bytes]]:
    """One solve in a worker: its outcome and its files (none when it failed)."""
    from motionkit.trajopt.compiled import install_libraries

    libraries, progress = shared
    install_libraries(libraries)
    config, name = TrajoptConfig.from_dict(task.config), task.name
    try:
        metrics, files = solve_files(config, name, task.robot, task.replay, progress)
    except MotionkitError as exc:
        return Outcome(name, False, str(exc), {}), {}
    return Outcome(name, True, summary_line(name, metrics), {k: metrics[k] for k in FIGURES}), files


def _portable(progress: Progress) -> Progress:
    """`progress` for the workers, where it can be pickled (else `silent` there)."""
    try:
        pickle.dumps(progress)
    except Exception:  # a lambda, a local function, an object holding a lock ...
        return silent
    return progress


def _compile_once(
    configs: list[TrajoptConfig], robot: Robot, progress: Progress
) -> dict[str, bytes]:
    """Build the compiled functions of each distinct jet model in `configs` here, once; their
    files, for the workers to install in their caches."""
    from motionkit.trajopt.compiled import LOADED, export_libraries
    from motionkit.trajopt.solve import Prepared

    first = len(LOADED)
    for config in {c.jets: c for c in configs}.values():
        Prepared(robot, config, log=progress)
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
