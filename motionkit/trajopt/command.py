"""`motionkit trajopt`: solve a flight scenario (or a grid of targets) and write MCAP clips."""

from __future__ import annotations

import argparse
import itertools
import os
import sys
import time as clock
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path
from typing import Any

from motionkit.cli import add_batch_options, echo, recipe_argument
from motionkit.core.errors import TrajoptError
from motionkit.core.extras import require
from motionkit.robot import load_robot
from motionkit.trajopt.config import SCENARIOS, TrajoptConfig
from motionkit.trajopt.runner import (
    check_clips,
    clip_stem,
    library_summary,
    solve_clip,
    solve_grid,
    solve_library,
    summary_line,
)

EPILOG = """\
Built-in recipes for every scenario: `motionkit recipes trajopt`. Targets are world positions [m] of
the centre of mass; the robot starts at the origin facing its spec's forward direction (-x for
iRonCub, whose root link x axis points backwards). Each solution is checked (residuals,
complementarity, target within 1 cm, thrust limits, MuJoCo replay open loop and stabilised by base
feedback through the jets, which must track the plan within [replay] max_base_error); a request that
cannot be solved exits with status 1 and writes nothing. --library FILE solves every clip a flight
library names (the built-in one: --library library). With --grid or --library, --cluster ADDRESS
solves on a Ray cluster (the [cluster] extra; the derivatives are compiled here once and sent to
the workers, this process writes the files). A --grid or --library batch writes each clip as soon
as it is solved and keeps the clips in --out that are up to date (same config, robot, code and
libraries), so that after a failure or an interrupt the same command solves only what is
missing (--resume, the default); --force solves every clip again."""


def add_commands(
    stages: argparse._SubParsersAction, robot_source: Callable[[argparse.ArgumentParser], None]
) -> None:
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
        "--library",
        type=recipe_argument("trajopt"),
        help="a TOML naming many solves (built-in: library)",
    )
    parser.add_argument(
        "--config",
        type=recipe_argument("trajopt"),
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
    add_batch_options(parser, "--grid and --library solves")
    parser.add_argument(
        "--force",
        action="store_true",
        help="with --grid or --library: solve every clip again, up to date or not",
    )
    robot_source(parser)
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


def _run(args: argparse.Namespace) -> int | None:
    require("trajopt", "motionkit trajopt", TrajoptError)  # before solve.py imports casadi
    if args.cluster:
        require("cluster", "--cluster", TrajoptError)
    if args.library is not None:
        return _run_library(args)
    if args.scenario is None:
        raise TrajoptError("--scenario is required (or --library FILE)")
    config = _config(args)
    robot = load_robot(args.urdf, args.spec)
    if args.grid is None:
        if args.cluster or args.resume or args.force:
            raise TrajoptError("--cluster, --resume and --force apply to --grid and --library")
        name = args.name or clip_stem(config)
        check_clips(args.out, [name])  # an --out it cannot write is exit 2, before the solve
        try:
            metrics = solve_clip(config, args.out, name, robot, not args.no_replay, progress=echo)
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
    targets = list(itertools.product(*axes))
    outcomes = solve_grid(config, targets, args.out, robot, args.jobs, not args.no_replay,
                          args.cluster, _resume(args), progress=echo)  # fmt: skip
    failed = sum(not o.solved for o in outcomes)
    print(f"{len(targets) - failed} of {len(targets)} targets solved; clips in {args.out}")
    return 1 if failed else None


LIBRARY_ONLY = ("scenario", "config", "name", "target", "height", "start", "knots", "grid")


def _run_library(args: argparse.Namespace) -> int | None:
    start = clock.perf_counter()
    clashing = [f"--{key}" for key in LIBRARY_ONLY if getattr(args, key) is not None]
    if clashing:
        raise TrajoptError(f"--library names its own scenarios and targets: drop {clashing}")
    robot = load_robot(args.urdf, args.spec)
    outcomes = solve_library(args.library, args.out, robot, args.jobs, not args.no_replay,
                             args.quiet, args.cluster, _resume(args), progress=echo)  # fmt: skip
    print(library_summary(outcomes, clock.perf_counter() - start, args.jobs, args.cluster))
    print(f"clips in {args.out}")
    return 1 if any(not o.solved for o in outcomes) else None


def _resume(args: argparse.Namespace) -> bool:
    """Whether a batch keeps its up-to-date clips: yes unless --force (--resume, the default,
    says so explicitly)."""
    if args.force and args.resume:
        raise TrajoptError("--force solves every clip again, --resume keeps the solved: drop one")
    return not args.force
