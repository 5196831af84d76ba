"""`motionkit view PATH | --robot`: a thin wrapper over motionkit.viewer.ViewerApp."""

from __future__ import annotations

import argparse
import math
from pathlib import Path
from typing import Any

from motionkit.core.errors import ViewerError
from motionkit.core.extras import require
from motionkit.viewer.skeleton import SKELETON_OFFSET

VIEW_EPILOG = """\
PATH is an MCAP clip, a folder of clips or a training run (searched recursively for *.mcap,
newest first). Every clip's metadata, and the whole first clip, are checked before the server
starts (the checks of `motionkit dataset validate`; a clip made for another model of the robot
is shown with a warning); a missing, corrupt or invalid file is an error naming it, and a clip
picked later that fails is reported on the page. The server listens on 127.0.0.1 only (the next
free port when --port is taken, as it says): from another machine, forward the port
(ssh -L 8080:127.0.0.1:8080 host).

The page plays the motion (timeline, play/pause, speed, loop, clip picker), draws thrust arrows
(length proportional to T/T_max, along the exhaust), sole corners green in contact, the centre of
mass, the waypoints of rollouts, the planned contact forces of optimised flights (an arrow per sole
corner, 0.5 m per body weight) and the scaled human skeleton of retargeted clips (beside the robot,
--skeleton-offset metres to its left), and plots joint angles and thrust. A clip with a
throttle channel (fitted jets: `motionkit play`, evaluation rollouts; optimised flights) also
shows the engines' lag: per jet, the commanded throttle and the thrust as two bars at the
current frame (folder "Engines") and as a time plot. --robot shows the model alone with a
slider per joint and the named frames (soles, sole corners, jets, elbows)."""


def add_commands(stages: argparse._SubParsersAction, robot_source: Any) -> None:
    view = stages.add_parser(
        "view",
        help="watch clips, datasets, rollouts or the robot in the browser (viser)",
        description="Open a browser viewer of motion clips or of the robot model.",
        epilog=VIEW_EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    view.add_argument("path", nargs="?", type=Path, metavar="PATH", help="clip, folder or run")
    view.add_argument("--robot", action="store_true", help="the robot model alone")
    view.add_argument("--port", type=int, default=8080, help="port on 127.0.0.1 (default 8080)")
    view.add_argument("--play", action="store_true", help="start playing at once")
    view.add_argument(
        "--skeleton-offset",
        type=float,
        default=SKELETON_OFFSET,
        metavar="METRES",
        help="draw a retargeted clip's human skeleton this far to the robot's left (default "
        f"{SKELETON_OFFSET:g}; 0 overlays it on the robot)",
    )
    robot_source(view)
    view.set_defaults(handler=_view)


def _view(args: argparse.Namespace) -> int:
    if (args.path is None) == (not args.robot):
        raise ViewerError("give a clip, folder or run (PATH), or --robot, but not both")
    if not 0 < args.port < 65536:
        raise ViewerError(f"--port must be 1 to 65535, got {args.port}")
    if not math.isfinite(args.skeleton_offset):
        raise ViewerError(
            f"--skeleton-offset must be a finite distance [m], got {args.skeleton_offset}"
        )
    require("viewer", "the viewer", ViewerError)
    from motionkit.robot import load_robot
    from motionkit.viewer.app import ViewerApp
    from motionkit.viewer.sources import resolve_clips

    clips = resolve_clips(args.path) if args.path is not None else []  # before the robot: fast
    robot = load_robot(args.urdf, args.spec)
    app = ViewerApp(
        robot, clips, port=args.port, play=args.play, skeleton_offset=args.skeleton_offset
    )
    shown = f"{len(clips)} clip(s) from {args.path}" if clips else f"robot {robot.name}"
    moved = app.port_note()
    if moved:
        print(f"motionkit view: {moved}", flush=True)
    print(f"motionkit view: {shown} at {app.url} (Ctrl-C to stop)", flush=True)
    try:
        app.wait()
    except KeyboardInterrupt:
        pass
    finally:
        app.close()
    return 0
