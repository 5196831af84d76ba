"""The `motionkit` command: thin wrappers over the stage functions."""

from __future__ import annotations

import argparse
import json
import os
import re
import signal
import sys
import threading
from collections.abc import Callable, Sequence
from pathlib import Path

from motionkit import __version__, recipes
from motionkit.core.errors import MotionkitError, RobotModelError
from motionkit.files.outputs import check_writable, write_text_atomic
from motionkit.recipes import STAGES as STAGE_CHOICES

ROBOT_EPILOG = """\
Without --urdf the robot is iRonCub, built from the installed icub-models package. A user robot
is its URDF plus a spec TOML (--spec) shaped like motionkit/robot/ironcub.toml: joint order,
feet and sole corners, jet frames with their maximum thrust, standing posture."""


_CLUSTER_ADDRESS = re.compile(r"^(?:ray://)?(?:[A-Za-z0-9._-]+|\[[0-9A-Fa-f:]+\]):(\d{1,5})$")


def recipe_argument(stage: str) -> Callable[[str], Path]:
    """An argparse `type` for `--config`: the recipe's path (a usage error when not found)."""

    def parse(text: str) -> Path:
        try:
            return recipes.find(stage, text)
        except recipes.RecipeError as exc:
            raise argparse.ArgumentTypeError(str(exc)) from None

    return parse


def cluster_address(text: str) -> str:
    """argparse type of --cluster: `auto`, `HOST:PORT` or `ray://HOST:PORT`."""
    match = _CLUSTER_ADDRESS.match(text.strip())
    if text.strip() == "auto" or (match and 0 < int(match[1]) < 65536):
        return text.strip()
    raise argparse.ArgumentTypeError(
        f"{text!r}: expected a Ray cluster address: auto, HOST:PORT or ray://HOST:PORT"
    )


def add_batch_options(parser: argparse.ArgumentParser, tasks: str) -> None:
    """--cluster and --resume, for a command that runs many `tasks`."""
    parser.add_argument(
        "--cluster",
        type=cluster_address,
        metavar="ADDRESS",
        help=f"run the {tasks} on a Ray cluster: auto, HOST:PORT or ray://HOST:PORT "
        "(the [cluster] extra; --jobs is then the cluster's CPUs)",
    )
    parser.add_argument(
        "--resume",
        action="store_true",
        help=f"keep the {tasks} whose outputs are up to date (same inputs, config and code)",
    )


def echo(line: str) -> None:
    """The commands' progress callback (motionkit.runtime.progress): each line on stdout at once. At
    module level, so that worker processes can take it too."""
    print(line, flush=True)


def add_robot_source(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--urdf", type=Path, help="a user robot's URDF (default: iRonCub)")
    parser.add_argument("--spec", type=Path, help="the user robot's spec TOML (with --urdf)")


def _robot_info(args: argparse.Namespace) -> None:
    from motionkit.robot import load_robot

    robot = load_robot(args.urdf, args.spec)
    info = robot.info()
    if args.json:
        print(json.dumps(info, indent=2))
        return
    print(f"{info['name']}  (model {info['model_hash']}; {info['origin']})")
    print(
        f"total mass {info['total_mass_kg']:.4f} kg; root {info['root']}, "
        f"facing {info['forward_in_root']} in the root frame"
    )
    print(
        f"\n{len(info['joints'])} actuated joints      lower [rad]  upper [rad]  vel [rad/s]  "
        "effort [N m]"
    )
    for i, joint in enumerate(info["joints"]):
        print(
            f"  {i:2d} {joint['name']:<18} {joint['lower_rad']:11.3f}  {joint['upper_rad']:11.3f}"
            f"  {joint['velocity_rad_s']:11.2f}  {joint['effort_nm']:12.1f}"
        )
    print(f"locked at zero: {', '.join(info['locked_joints']) or 'none'}")
    print(f"\n{len(info['jets'])} jets (thrust along -z of the frame)")
    for jet in info["jets"]:
        print(f"  {jet['name']:<12} frame {jet['frame']:<22} T_max {jet['t_max_n']:.0f} N")
    print("\nfeet")
    for foot in info["feet"]:
        print(f"  {foot['side']:<6} sole {foot['sole']}, corners {', '.join(foot['corners'])}")
    print(f"elbows: {', '.join(info['elbows'])}")


def _robot_export(args: argparse.Namespace) -> None:
    from motionkit.robot import load_robot

    check_writable(args.out, RobotModelError)
    robot = load_robot(args.urdf, args.spec)  # validated before anything is written
    text = robot.urdf_text if args.format == "urdf" else robot.mjcf_text
    out = Path(args.out)
    path = out / f"{robot.name}.{'urdf' if args.format == 'urdf' else 'xml'}"
    write_text_atomic(path, text)
    print(f"wrote {path} ({args.format}, model {robot.model_hash})")


def _recipes(args: argparse.Namespace) -> None:
    from motionkit import recipes

    stages = [args.stage] if args.stage else list(recipes.STAGES)
    if args.show:
        found = [r for s in stages for r in recipes.builtin(s) if r.name == args.show]
        if len(found) != 1:
            where = "several stages (name one)" if found else "no built-in recipe"
            raise recipes.RecipeError(f"{args.show}: {where}; see `motionkit recipes`")
        print(found[0].path.read_text(), end="")
        return
    for stage in stages:
        print(f"{stage}:")
        for recipe in recipes.builtin(stage):
            print(f"  {recipe.name:<20} {recipe.summary}")
    print(f"\n(in {recipes.ROOT}; pass a name to --config, or copy one with --show NAME > my.toml)")


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="motionkit",
        description="Motion priors for a flying humanoid (iRonCub): mocap retargeting, flight "
        "trajectory optimisation, jet identification, MCAP datasets and an AMP trainer.",
    )
    parser.add_argument("--version", action="version", version=f"motionkit {__version__}")
    stages = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")

    robot = stages.add_parser(
        "robot",
        help="inspect and export the robot model",
        description="The robot model every stage shares.",
        epilog=ROBOT_EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    robot_commands = robot.add_subparsers(dest="robot_command", required=True, metavar="ACTION")
    info = robot_commands.add_parser(
        "info", help="joints, limits, mass, jets and frames", epilog=ROBOT_EPILOG
    )
    add_robot_source(info)
    info.add_argument("--json", action="store_true", help="print JSON instead of a table")
    info.set_defaults(handler=_robot_info)
    export = robot_commands.add_parser(
        "export",
        help="write the model as URDF or MJCF",
        epilog=ROBOT_EPILOG,
        description="Write the robot as URDF (meshes from the installed icub-models) or MJCF "
        "(free base on a floor, box soles, PD position actuators, one thrust actuator per jet, "
        "keyframe 'stand').",
    )
    add_robot_source(export)
    export.add_argument("--format", choices=("urdf", "mjcf"), required=True)
    export.add_argument("--out", type=Path, required=True, help="output folder")
    export.set_defaults(handler=_robot_export)

    listing = stages.add_parser(
        "recipes",
        help="list the built-in recipes (found by name with --config)",
        description="The recipes shipped with motionkit, by stage, with their first comment "
        "line. Every command's --config takes one by name, or a TOML file of your own.",
    )
    listing.add_argument("stage", nargs="?", choices=STAGE_CHOICES, help="one stage only")
    listing.add_argument("--show", metavar="NAME", help="print the recipe's TOML")
    listing.set_defaults(handler=_recipes)

    from motionkit.dataset.command import add_commands as add_dataset_commands

    add_dataset_commands(stages, add_robot_source)
    from motionkit.retarget.command import add_commands as add_retarget_commands

    add_retarget_commands(stages, add_robot_source)
    from motionkit.jet_ident.command import add_commands as add_jet_commands

    add_jet_commands(stages)
    from motionkit.trajopt.command import add_commands as add_trajopt_commands

    add_trajopt_commands(stages, add_robot_source)
    from motionkit.train.command import add_commands as add_train_commands

    add_train_commands(stages, add_robot_source)
    from motionkit.train.play_command import add_commands as add_play_commands

    add_play_commands(stages, add_robot_source)
    from motionkit.viewer.command import add_commands as add_view_commands

    add_view_commands(stages, add_robot_source)
    from motionkit.viewer.render_command import add_commands as add_render_commands

    add_render_commands(stages, add_robot_source)
    from motionkit.pipeline.command import add_commands as add_pipeline_commands

    add_pipeline_commands(stages, add_robot_source)
    return parser


# a comma-separated list of numbers that starts with a minus sign, e.g. "-1,0" in --grid
_NEGATIVE_LIST = re.compile(r"^-\.?\d[\d.eE+-]*(,[-+]?\.?\d[\d.eE+-]*)+$")


def values_not_options(argv: Sequence[str]) -> list[str]:
    """argparse takes "-1,0" for an option; a leading space makes it a value (float() and int()
    ignore the space). Single negative numbers argparse recognises itself."""
    return [f" {arg}" if _NEGATIVE_LIST.match(arg) else arg for arg in argv]


class Terminated(KeyboardInterrupt):
    """SIGTERM, raised in the main thread like Ctrl-C's KeyboardInterrupt: the same cleanup runs
    (worker processes ended, temporary files removed, a pipeline stage's previous output kept)."""


def _terminate(signum: int, frame: object) -> None:
    raise Terminated


def main(argv: Sequence[str] | None = None) -> int:
    """The command's exit status: 0, 1 (some items failed), 2 (an error, one line), 130
    (interrupted by Ctrl-C) or 143 (SIGTERM)."""
    in_main_thread = threading.current_thread() is threading.main_thread()
    previous = signal.signal(signal.SIGTERM, _terminate) if in_main_thread else None
    try:
        args = build_parser().parse_args(values_not_options(sys.argv[1:] if argv is None else argv))
        return args.handler(args) or 0
    except MotionkitError as exc:
        print(f"motionkit: error: {exc}", file=sys.stderr)
        return 2
    except Terminated:
        print("motionkit: terminated", file=sys.stderr)
        return 128 + signal.SIGTERM
    except KeyboardInterrupt:
        print("motionkit: interrupted", file=sys.stderr)
        return 128 + signal.SIGINT
    except BrokenPipeError:  # `motionkit ... | head`: the reader left; end quietly
        # (not SIGPIPE's default action: it would kill this process on a dead worker's pipe)
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 141  # 128 + SIGPIPE, what a shell shows for a process the signal ended
    finally:
        if previous is not None:
            signal.signal(signal.SIGTERM, previous)


if __name__ == "__main__":
    sys.exit(main())
