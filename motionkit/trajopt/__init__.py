"""Centroidal trajectory optimisation of any jet-powered robot with contacts, CasADi + IPOPT.

    from motionkit.robot import load_robot
    from motionkit.trajopt import Prepared, TrajoptConfig, solve_clip, solve_library

    robot = load_robot("robot.urdf", "robot.toml")       # no arguments: iRonCub
    config = TrajoptConfig.from_toml("trajopt/takeoff.toml").with_scenario(target=(0, 0, 1.0))
    metrics = solve_clip(config, out, "takeoff", robot)  # solve, check, replay, write the clip
    outcomes = solve_library("trajopt/library.toml", out, robot, jobs=2, progress=print)
    solution = Prepared(robot, config).solve()           # the knots alone, nothing written

`solve_grid` solves one config for many targets; the runs print nothing unless given a
`progress` callback (`print`: the solves' lines); `read_library` lists a library's solves
(LibrarySolve), `summary_line` and `library_summary` are the lines `motionkit trajopt` prints;
SCENARIOS names the scenarios. Configs, libraries and the runners import without the
[trajopt] extra (CasADi); `Prepared`, `Solution` and `check_solution` import it on
first use, and a run without it is a TrajoptError naming the extra.
"""

from __future__ import annotations

import importlib
from typing import Any

from motionkit.core.errors import TrajoptError
from motionkit.core.extras import require
from motionkit.trajopt.config import SCENARIOS, TrajoptConfig
from motionkit.trajopt.library import LibrarySolve, read_library
from motionkit.trajopt.runner import (
    library_summary,
    solve_clip,
    solve_grid,
    solve_library,
    summary_line,
)

_LAZY = {"Prepared": "solve", "Solution": "solve", "check_solution": "checks"}

__all__ = [
    "SCENARIOS",
    "LibrarySolve",
    "TrajoptConfig",
    "library_summary",
    "read_library",
    "solve_clip",
    "solve_grid",
    "solve_library",
    "summary_line",
    *_LAZY,
]


def __getattr__(name: str) -> Any:
    if name in _LAZY:
        require("trajopt", f"motionkit.trajopt.{name}", TrajoptError)
        return getattr(importlib.import_module(f"motionkit.trajopt.{_LAZY[name]}"), name)
    raise AttributeError(f"module 'motionkit.trajopt' has no attribute {name!r}")
