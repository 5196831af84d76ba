"""`motionkit play`: a thin wrapper over motionkit.train.play."""

from __future__ import annotations

import argparse
import math
from collections.abc import Callable
from pathlib import Path
from typing import Any

from motionkit.core.errors import TrainError, ViewerError
from motionkit.core.extras import require
from motionkit.files.outputs import check_out, inside
from motionkit.robot import load_robot
from motionkit.train.runtime import require_train_extra

EPILOG = """\
The policy: a training run's folder (OUT of `motionkit train`: config.toml and
checkpoint.msgpack), a policy package of `motionkit train export`, or the name of a policy
shipped with motionkit (motionkit/policies/NAME; the default, when one ships).

The robot starts standing and pursues the waypoints one after the other, as in training: the
current one relative to the base in the observation, reached within [env] waypoint_radius of
the base (0.3 m); unlike training, a waypoint has no deadline. The run ends after the last
waypoint, at a fall or after --seconds. The physics is MuJoCo C (the training's CPU backend,
mujoco.batch) on the training environment's model, at its control rate and substeps; the
observation, PD targets and jets are the environment's own functions.

Output: OUT/NAME.mcap, a motion clip (`motionkit dataset validate`, `motionkit view`) with the
waypoints in its metadata. Printed: per waypoint when it was reached, walking or flying (the
share of the way with both soles off the ground), the share on one foot and the contact
switches per foot per second, the mean thrust; falls; the real-time factor (simulated / wall
seconds, compilation not counted). With fitted jets ([env] jet = "lstm", "grey_box" or
"selected") the clip also holds each jet's commanded throttle [%] beside its thrust, and
`motionkit view` shows both per jet (the engines' lag).

  motionkit play --waypoints "1.5,0,0.6 3,1,0.6" --out plays   # the shipped policy

  motionkit play --policy runs/tiny --waypoints "1,0,0.6 1,1,1.2" --out plays
  motionkit play --policy policies/walk_fly --random-route 6 --seed 3 --out plays
  motionkit play --policy runs/walk_fly_jets --waypoints "1.5,0,0.6 3,1,1.2" --out plays
  motionkit play --policy runs/tiny --view --seconds 60 --out plays   # place waypoints by clicks

On a terrain (--terrain KIND[:LEVEL], a policy of the terrain scenario): the robot starts on
the pad of that tile (flat, rough, stones or pits; without a level, the hardest) of a course
training did not use (numbered by --seed), --waypoints are x, y from the tile's centre, a
random route crosses the tile as training's do, and the clip records the terrain under the
robot (drawn by `motionkit view` and `motionkit render`).

  motionkit play --policy runs/terrain --terrain pits:9 --random-route 3 --seed 2 --out plays"""


def add_commands(
    stages: argparse._SubParsersAction, robot_source: Callable[[argparse.ArgumentParser], None]
) -> None:
    parser = stages.add_parser(
        "play",
        help="roll a trained policy out on the CPU (MuJoCo C) toward waypoints; write a clip",
        description="Roll a trained walking-and-flying policy out from the standing pose toward "
        "waypoints, in real time or faster on the CPU, and write the motion as an MCAP clip.",
        epilog=EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("--policy", help="run folder, policy folder or shipped policy name")
    parser.add_argument(
        "--waypoints",
        metavar='"x,y,z x,y,z ..."',
        help="base positions to reach, world frame [m] (default: a random route)",
    )
    parser.add_argument(
        "--random-route",
        type=int,
        default=4,
        metavar="N",
        help="without --waypoints: N waypoints drawn as training draws them (default 4)",
    )
    parser.add_argument(
        "--seed", type=int, default=0, help="of the random route and the course (default 0)"
    )
    parser.add_argument(
        "--terrain",
        metavar="KIND[:LEVEL]",
        help="play on this tile of a held-out course (a terrain policy; no level: the hardest)",
    )
    parser.add_argument(
        "--seconds", type=float, default=20.0, help="longest rollout [s] (default 20)"
    )
    parser.add_argument("--out", type=Path, required=True, help="output folder (required)")
    parser.add_argument("--name", default="play", help="clip name: OUT/NAME.mcap (default play)")
    parser.add_argument(
        "--view", action="store_true", help="show it live in the browser; clicks add waypoints"
    )
    parser.add_argument("--port", type=int, default=8080, help="of --view (default 8080)")
    robot_source(parser)
    parser.set_defaults(handler=_play)


def _play(args: argparse.Namespace) -> int:
    from motionkit.train.play import parse_waypoints

    route = None if args.waypoints is None else parse_waypoints(args.waypoints)
    if not (math.isfinite(args.seconds) and args.seconds > 0):
        raise TrainError(f"--seconds {args.seconds}: expected a duration > 0")
    if route is None and args.random_route < 1:
        raise TrainError(f"--random-route {args.random_route}: at least 1 waypoint")
    if args.view and not 0 < args.port < 65536:
        raise TrainError(f"--port must be 1 to 65535, got {args.port}")
    path = inside(args.out, f"{args.name}.mcap", TrainError)
    if path.parent != args.out:
        raise TrainError(f"--name {args.name!r}: a plain name, not a path")
    check_out(args.out, [path.name], TrainError)
    require_train_extra("play")
    if args.view:
        require("viewer", "play --view", ViewerError)
    from motionkit.train.play import play, report
    from motionkit.train.policy import load_policy

    policy = load_policy(args.policy)
    robot = load_robot(args.urdf, args.spec)
    views: list[Any] = []

    def live(env: Any, route: list, start: Any) -> Any:
        from motionkit.viewer.live import LiveView

        x, y = float(start[0]), float(start[1])
        height = env.config.ground_height
        view = LiveView(robot, route, height=height, start=(x, y, 0), port=args.port)
        views.append(view)
        print(f"motionkit play: live at {view.url} (Ctrl-C to stop)", flush=True)
        return view.watch

    print(f"motionkit play: {policy.source}", flush=True)
    try:
        played, _ = play(
            policy,
            robot,
            path,
            route=route,
            count=args.random_route,
            seed=args.seed,
            seconds=args.seconds,
            live=live if args.view else None,
            terrain=args.terrain,
        )
    finally:
        for view in views:
            view.close()
    for line in report(played):
        print(line)
    print(f"wrote {path} ({played.frames} frames at {played.control_hz:g} Hz)")
    return 0
