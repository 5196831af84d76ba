"""`motionkit render CLIP --out FILE.gif|.mp4`: a thin wrapper over motionkit.viewer.render."""

from __future__ import annotations

import argparse
from collections.abc import Callable
from pathlib import Path

from motionkit.core.errors import ViewerError
from motionkit.core.extras import require
from motionkit.viewer.offscreen import default_gl, import_mujoco
from motionkit.viewer.render import RenderConfig

EPILOG = """\
CLIP is an MCAP clip written by motionkit: a `motionkit play` clip, a retargeted or optimised
prior, a training rollout (RUN/rollouts/iter_N.mcap). It is checked as `motionkit dataset
validate` checks it; a missing, corrupt or invalid clip is a one-line error and nothing is
written. The file appears only once the whole animation is written.

The picture: the robot with its meshes on a checker floor (0.5 m squares), the camera following
its base from --azimuth degrees about the vertical from the robot's mean front over the cut (a
fixed direction, so that turns show), a flame out of each firing jet along the exhaust (0.6 m at
T_max), the clip's waypoints as blue balls on poles, the clip's name and time in a corner. One
picture every 1/--fps s of clip time, showing the clip's last frame at or before it.

OpenGL: MuJoCo's offscreen renderer with the backend MUJOCO_GL names; unset, egl (Mesa's EGL
renders without a display or GPU: apt-get install libegl1 libgl1-mesa-dri). A GIF needs Pillow;
an MP4 needs imageio-ffmpeg (pip install imageio-ffmpeg) and an even width and height.

  motionkit render plays/play.mcap --out play.gif
  motionkit render runs/walk/rollouts/iter_3000.mcap --out walk.mp4 --width 960 --height 720
  motionkit render flight/takeoff.mcap --out takeoff.gif --start 1 --seconds 2 --azimuth 90"""


def add_commands(
    stages: argparse._SubParsersAction, robot_source: Callable[[argparse.ArgumentParser], None]
) -> None:
    default = RenderConfig()
    parser = stages.add_parser(
        "render",
        help="draw a clip into a GIF or an MP4 (MuJoCo's offscreen renderer, no browser)",
        description="Draw a motion clip into an animated GIF or an MP4 with MuJoCo's offscreen "
        "renderer: the robot's meshes, a floor, a camera following the base, thrust, waypoints.",
        epilog=EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("clip", type=Path, metavar="CLIP", help="an MCAP clip")
    parser.add_argument("--out", type=Path, required=True, help="the .gif or .mp4 to write")
    parser.add_argument(
        "--fps",
        type=float,
        default=default.fps,
        help=f"pictures per second (default {default.fps:g})",
    )
    parser.add_argument(
        "--width", type=int, default=default.width, help=f"pixels (default {default.width})"
    )
    parser.add_argument(
        "--height", type=int, default=default.height, help=f"pixels (default {default.height})"
    )
    parser.add_argument(
        "--start", type=float, default=0.0, help="s after the clip's first frame (default 0)"
    )
    parser.add_argument(
        "--seconds", type=float, help="s of clip from --start (default: to the end)"
    )
    parser.add_argument(
        "--distance",
        type=float,
        default=default.distance,
        help=f"camera to base [m] (default {default.distance:g})",
    )
    parser.add_argument(
        "--azimuth",
        type=float,
        default=default.azimuth,
        help="camera direction [deg] about the vertical from the robot's mean front, 90 its left "
        f"(default {default.azimuth:g})",
    )
    parser.add_argument(
        "--elevation",
        type=float,
        default=default.elevation,
        help=f"camera view above the horizon [deg], negative looks down (default "
        f"{default.elevation:g})",
    )
    parser.add_argument("--no-shadows", action="store_true", help="faster, without shadows")
    robot_source(parser)
    parser.set_defaults(handler=_render)


def _render(args: argparse.Namespace) -> int:
    default_gl()  # MUJOCO_GL=egl when unset, before mujoco is imported
    config = RenderConfig(
        fps=args.fps,
        width=args.width,
        height=args.height,
        start=args.start,
        seconds=args.seconds,
        distance=args.distance,
        azimuth=args.azimuth,
        elevation=args.elevation,
        shadows=not args.no_shadows,
    )
    require("viewer", "motionkit render", ViewerError, ("trimesh",))
    import_mujoco()  # the [train] extra, and an OpenGL backend that lets mujoco import
    from motionkit.robot import load_robot
    from motionkit.viewer.render import render_clip

    robot = load_robot(args.urdf, args.spec)

    def progress(line: str) -> None:
        print(f"motionkit render: {line}", flush=True)

    rendered = render_clip(args.clip, args.out, robot, config, progress)
    for warning in rendered.warnings:
        print(f"motionkit render: warning: {warning}")
    print(
        f"wrote {rendered.path}: {rendered.frames} frames at {config.fps:g} fps, "
        f"{config.width}x{config.height}, {rendered.seconds:.2f} s of the clip from "
        f"{rendered.start:.2f} s; {1000 * rendered.seconds_per_frame:.0f} ms per frame to draw"
    )
    return 0
