"""`motionkit retarget` and `motionkit mocap fetch`: thin wrappers over motionkit.retarget."""

from __future__ import annotations

import argparse
import os
import sys
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path

from motionkit.cli import add_batch_options, echo, recipe_argument
from motionkit.core.errors import RetargetError
from motionkit.core.extras import require
from motionkit.files.outputs import check_out
from motionkit.retarget.batch import ClipResult, clip_line, resolve_inputs, run_retarget
from motionkit.retarget.config import RetargetConfig
from motionkit.robot import load_robot

RETARGET_EPILOG = """\
INPUT is a .bvh file, an .amc file (its skeleton: <subject>.asf beside it, or the only .asf in
its folder), a folder (searched recursively), or a CMU clip id such as 02_01 (downloaded into the
cache first, see `motionkit mocap fetch`). A recipe (--config: a file or a built-in
name such as cmu_walk) can list clips too; its settings are RetargetConfig's fields
(motionkit/retarget/config.py).

Each clip becomes DIR/<name>.mcap with the resolved config and its quality metrics in the
metadata; DIR/retarget_summary.json holds every clip's metrics and stage times. A clip that
fails writes nothing and makes the exit status 1. So does a clip beyond the figures of a clean
walk (the quality gate: foot slide p95 > 0.3 cm/s, penetration > 1 mm, any limit violation,
mean foot error > 3 cm; a recipe's [quality] table sets other limits), unless --keep-failed DIR2
is given: such clips are then written to DIR2, never where priors are read.

--cluster ADDRESS runs the clips on a Ray cluster (the [cluster] extra) instead of local
processes; this process writes every clip. --resume keeps the clips whose output is up to date
(same input files, config, robot and code), so a sweep that was stopped does only the rest.

The balance filter ([balance] in a recipe; --no-balance skips it) then shifts the base so that
the centre of pressure the motion needs stays inside the feet's support, and solves the IK
again; the physics figures (motionkit dataset check-physics) go into each clip's metadata."""


def add_commands(
    stages: argparse._SubParsersAction, robot_source: Callable[[argparse.ArgumentParser], None]
) -> None:
    retarget = stages.add_parser(
        "retarget",
        help="human mocap (BVH, ASF/AMC, CMU clip ids) onto the robot with PlaCo IK",
        description="Retarget human motion capture onto the robot: scaling by leg length, "
        "contact detection, feet flat and locked in contact, PlaCo inverse kinematics within "
        "joint position and velocity limits; one MCAP clip per input.",
        epilog=RETARGET_EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    retarget.add_argument("inputs", nargs="*", metavar="INPUT", help="files, folders, clip ids")
    retarget.add_argument("--out", type=Path, required=True, help="output folder")
    retarget.add_argument(
        "--config",
        type=recipe_argument("retarget"),
        help="recipe: a TOML file or a built-in name (default: the defaults)",
    )
    retarget.add_argument(
        "--jobs", type=int, default=1, help="parallel processes (default 1; 0 = one per CPU)"
    )
    add_batch_options(retarget, "clips")
    retarget.add_argument("--kind", help="dataset label of the outputs (default: the config's)")
    retarget.add_argument(
        "--keep-failed",
        type=Path,
        metavar="DIR",
        help="write the clips beyond the quality gate to DIR (another folder) instead of failing",
    )
    retarget.add_argument(
        "--no-balance",
        action="store_true",
        help="skip the balance filter (kinematic retargeting only, about 3x faster)",
    )
    robot_source(retarget)
    retarget.set_defaults(handler=_retarget)

    mocap = stages.add_parser(
        "mocap",
        help="download CMU motion-capture clips",
        description="Human motion capture files.",
    )
    actions = mocap.add_subparsers(dest="mocap_command", required=True, metavar="ACTION")
    fetch = actions.add_parser(
        "fetch",
        help="download CMU clips (ASF/AMC) into the cache",
        description="Download clips of the CMU Graphics Lab Motion Capture Database "
        "(mocap.cs.cmu.edu; free for research and commercial use) into the user cache; files "
        "already there and complete are not downloaded again. Prints each clip's AMC and ASF.",
    )
    fetch.add_argument("clips", nargs="+", metavar="CLIP", help="clip ids, e.g. 02_01 143_05")
    fetch.add_argument("--cache", type=Path, help="folder to store the clips (default: cache)")
    fetch.add_argument("--base-url", default=None, help=argparse.SUPPRESS)  # tests: a local server
    fetch.set_defaults(handler=_fetch)


def _fetch(args: argparse.Namespace) -> None:
    from motionkit.mocap.fetch import CMU_BASE_URL, fetch_clips

    for amc, asf in fetch_clips(args.clips, args.cache, args.base_url or CMU_BASE_URL):
        print(f"{amc.stem}  {amc}  {asf}")


def _retarget(args: argparse.Namespace) -> int:
    config = RetargetConfig.from_toml(args.config) if args.config else RetargetConfig()
    if args.kind:
        config = replace(config, kind=args.kind)
    if args.no_balance:
        config = replace(config, balance=replace(config.balance, passes=0))
    if args.jobs < 0:
        raise RetargetError(f"--jobs must be 0 (one per CPU) or more, got {args.jobs}")
    if args.cluster:
        require("cluster", "--cluster", RetargetError)  # before any download
    jobs = args.jobs or os.cpu_count() or 1
    check_out(args.out, [], RetargetError)  # before any download
    if args.keep_failed is not None:
        check_out(args.keep_failed, [], RetargetError)
    base = args.config.parent if args.config else Path.cwd()
    recipe = [str(base / c) if (base / c).exists() else c for c in config.clips]
    clips = resolve_inputs([*recipe, *args.inputs])
    robot = load_robot(args.urdf, args.spec)
    results = run_retarget(clips, args.out, config, jobs, robot, args.cluster, args.resume,
                           progress=echo, report=_report_clip, frames=True,
                           keep_failed=args.keep_failed)  # fmt: skip
    return 1 if any(r.output is None for r in results) else 0


def _report_clip(result: ClipResult, done: int, total: int) -> None:
    """A clip's line as it comes: on stderr when it failed."""
    stream = sys.stderr if result.output is None else sys.stdout
    print(clip_line(result, done, total), file=stream, flush=True)
