"""`motionkit pipeline`: run every stage, skipping those whose inputs did not change."""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable
from pathlib import Path

from motionkit.cli import cluster_address, echo, recipe_argument
from motionkit.core.errors import PipelineError
from motionkit.core.extras import require
from motionkit.pipeline.config import PipelineConfig
from motionkit.pipeline.runner import STAGE_NAMES, run_pipeline
from motionkit.robot import load_robot

DEFAULT_CONFIG = "tiny_cpu"

EPILOG = """\
Stages, in order, each into its folder of OUT:
  retarget   walk/      mocap clips onto the robot: the recipe's (the built-in sample of three
                        CMU walks), every .bvh/.amc under --mocap-dir, or with --fetch the
                        CMU clips of the fetch recipe, downloaded into the cache
  trajopt    flight/    one flight per trajopt recipe and every clip of the flight library
                        (take-offs, flights, landings, jumps, walk-to-fly), each checked
                        and replayed in MuJoCo
  jet_ident  jet/       simulated P250 bench logs and the LSTM thrust model fitted to them
  datasets   datasets/  every clip validated against the robot, its physics figures shown;
                        index.json
  train      train/     the AMP + PPO run (tiny CPU recipe; the paper's GPU recipe with --full)
Every stage works on the same robot (--urdf/--spec; default iRonCub). A stage runs again only
when what it reads changed: input files, its resolved recipe, the robot, the stages before it,
motionkit's code for it or its main libraries (the hash is its key, kept in OUT/.pipeline/).
A stage runs in OUT/.staging/ and replaces its folder only when it succeeds: a failing stage
keeps the previous output and the pipeline stops with status 2 (130 on Ctrl-C, 143 on SIGTERM).
--cluster ADDRESS runs the retarget clips and the flight library on a Ray cluster (same outputs,
same keys: a stage cached from a local run stays cached).
Folders and files in OUT that motionkit did not write are never replaced (the run is refused).
OUT/pipeline_summary.json holds the table printed at the end.

  motionkit pipeline                                   (the built-in sample, offline)
  motionkit pipeline --mocap-dir ~/mocap/cmu --out runs/pipeline
  motionkit view runs/pipeline/walk"""


def add_commands(
    stages: argparse._SubParsersAction, robot_source: Callable[[argparse.ArgumentParser], None]
) -> None:
    parser = stages.add_parser(
        "pipeline",
        help="everything from raw data to a trained policy, cached stage by stage",
        description="Retarget CMU mocap, optimise the flight scenarios, identify the jet model, "
        "check the datasets and train the walking-and-flying policy, in one command. Stages "
        "whose inputs did not change are not run again.",
        epilog=EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument(
        "--config",
        type=recipe_argument("pipeline"),
        default=DEFAULT_CONFIG,
        help=f"pipeline recipe: a TOML file or a built-in name (default: {DEFAULT_CONFIG})",
    )
    parser.add_argument("--out", type=Path, default=Path("runs/pipeline"),
                        help="output folder (default: runs/pipeline)")  # fmt: skip
    clips = parser.add_mutually_exclusive_group()
    clips.add_argument("--mocap-dir", type=Path, help="retarget every .bvh/.amc in this folder "
                       "instead of the recipe's clips")  # fmt: skip
    clips.add_argument("--fetch", action="store_true", help="retarget the CMU clips of the "
                       "fetch recipe (cmu_walk: 15 walks), downloading them once")  # fmt: skip
    parser.add_argument(
        "--full", action="store_true", help="train with the paper's GPU recipe, not the tiny one"
    )
    parser.add_argument("--force", action="store_true", help="run every stage, cached or not")
    parser.add_argument(
        "--cluster",
        type=cluster_address,
        metavar="ADDRESS",
        help="run the retarget clips and the trajopt library on a Ray cluster: auto, HOST:PORT "
        "or ray://HOST:PORT (the [cluster] extra)",
    )
    parser.add_argument(
        "--until",
        choices=STAGE_NAMES,
        help="stop after this stage (the later stages are neither run nor checked)",
    )
    robot_source(parser)
    parser.set_defaults(handler=_run)


def _require_extras() -> None:
    for extra in ("ik", "trajopt", "train"):
        require(extra, "the pipeline (every stage)", PipelineError)


def _run(args: argparse.Namespace) -> int:
    config = PipelineConfig.from_toml(args.config)
    _require_extras()
    if args.cluster:
        require("cluster", "--cluster", PipelineError)
    robot = load_robot(args.urdf, args.spec)
    if args.full:
        _warn_without_gpu()
    out = args.out.resolve()
    run_pipeline(
        config,
        out,
        robot,
        mocap_dir=args.mocap_dir,
        full=args.full,
        force=args.force,
        fetch=args.fetch,
        until=args.until,
        cluster=args.cluster,
        progress=echo,
    )
    if args.until and args.until != "train":
        return 0
    print(
        "\nWatch the results in the browser:\n"
        f"  motionkit view {out / 'walk'}      (retargeted walks, with the human skeleton)\n"
        f"  motionkit view {out / 'flight'}    (optimised flights, with contact forces)\n"
        f"  motionkit view {out / 'train'}     (the policy's evaluation rollouts)"
    )
    return 0


def _warn_without_gpu() -> None:
    import jax

    if jax.default_backend() == "cpu":
        print(
            "warning: --full trains with the paper's GPU recipe (4,096 environments) but JAX "
            "sees no GPU here; expect days instead of minutes",
            file=sys.stderr,
        )
