"""Human mocap onto any robot: PlaCo inverse kinematics with foot contacts, balance and clearance.

    from motionkit.mocap import load_mocap
    from motionkit.retarget import RetargetConfig, resolve_inputs, retarget, run_retarget
    from motionkit.robot import load_robot

    robot = load_robot("robot.urdf", "robot.toml")       # no arguments: iRonCub
    human = load_mocap("02_01.bvh")
    trajectory, timings = retarget(human.landmarks(), human.rate, robot, RetargetConfig())
    results = run_retarget(resolve_inputs(["walks/", "02_01"]), out, RetargetConfig(), 2, robot)

`retarget` is one clip in memory; `retarget_clip` / `retarget_all` (on an executor of
motionkit.runtime.executors) read and write MCAP clips from `resolve_inputs`' ClipInput list, each a
ClipResult; `run_retarget` adds the summary file, and gives the lines `motionkit retarget` prints
(progress, quality table) to its `progress` callback: nothing is shown unless one is passed
(`progress=print`). A robot other than iRonCub names its joints in the config's `points`. The IK
needs the [ik] extra (PlaCo), named in a RetargetError when it is missing.
"""

from motionkit.retarget.batch import (
    ClipInput,
    ClipResult,
    resolve_inputs,
    retarget_all,
    retarget_clip,
    run_retarget,
)
from motionkit.retarget.config import RetargetConfig
from motionkit.retarget.core import retarget

__all__ = [
    "ClipInput",
    "ClipResult",
    "RetargetConfig",
    "resolve_inputs",
    "retarget",
    "retarget_all",
    "retarget_clip",
    "run_retarget",
]
