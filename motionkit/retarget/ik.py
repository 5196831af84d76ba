"""Per-frame PlaCo inverse kinematics over a whole motion, warm-started frame to frame."""

from __future__ import annotations

import hashlib
import json
from collections.abc import Callable
from itertools import combinations
from typing import Any

import numpy as np

from motionkit.core.errors import RetargetError
from motionkit.core.extras import require
from motionkit.retarget.bodies import avoided, capsules, host_link, with_collision_cylinders
from motionkit.retarget.config import RetargetConfig
from motionkit.retarget.points import Point
from motionkit.retarget.targets import Targets
from motionkit.retarget.tasks import GroundGuard, Task, make_tasks
from motionkit.robot import Robot
from motionkit.robot.geometry import Array
from motionkit.robot.model import cached_file
from motionkit.runtime.silence import quiet_c_output


def kinematic_urdf(robot: Robot) -> str:
    """The robot's URDF without meshes (PlaCo loads it in milliseconds), cached by model hash."""
    model = robot.model.copy()
    for link in model.links.values():
        link.visuals, link.collisions = [], []
    return str(cached_file(robot, "kinematics.urdf", model.to_urdf(f"{robot.name} without meshes")))


def _load_wrapper(placo: Any, robot: Robot, points: dict[str, Point], avoid: bool) -> Any:
    """PlaCo's robot; with `avoid`, its collision model is the capsules of `bodies` (as
    cylinders), and the non-adjacent pairs with a jet or an upper arm in them are checked. Leg
    against leg is left to the metrics: the human's stance foot passes close to the swing leg,
    and pushing the legs apart would drag the locked foot."""
    if not avoid:
        return placo.RobotWrapper(kinematic_urdf(robot), placo.Flags.ignore_collisions)
    shapes, adjacent = capsules(robot, points)
    text = with_collision_cylinders(robot.model, shapes).to_urdf(f"{robot.name} with capsules")
    host = {c.name: host_link(robot.model, c) for c in shapes}
    pairs = [
        [host[a.name], host[b.name]]
        for a, b in combinations(shapes, 2)
        if frozenset((a.name, b.name)) not in adjacent and avoided(a, b)
    ]
    key = hashlib.sha256((text + json.dumps(pairs)).encode()).hexdigest()[:12]
    with quiet_c_output():  # PlaCo prints every pair that touches at the zero pose
        wrapper = placo.RobotWrapper(str(cached_file(robot, f"capsules-{key}.urdf", text)), 0)
    wrapper.load_collision_pairs(str(cached_file(robot, f"pairs-{key}.json", json.dumps(pairs))))
    return wrapper


def solve_motion(
    robot: Robot,
    targets: Targets,
    points: dict[str, Point],
    config: RetargetConfig,
    progress: Callable[[int], None] | None = None,
) -> tuple[Array, Array]:
    """The robot's motion that follows the targets, frame by frame, each solve warm-started
    from the last (the first frame settles from the standing posture).

    Args:
        robot: the robot; its spec names the root, the feet and the standing posture.
        targets: per-frame IK targets (T frames, world frame, m; see `Targets`).
        points: the robot points matched to the human's ('l_knee', ...; `robot_points`).
        config: the retargeting config (weights, iterations, limits, self-collisions).
        progress: called with each frame's index once it is solved.

    Returns:
        Base poses (T, 4, 4) (world frame, m) and joint positions (T, J) [rad] in spec order.
    """
    require("ik", "retargeting", RetargetError, ("placo",))
    import placo

    wrapper = _load_wrapper(placo, robot, points, config.self_collisions)
    _stand(wrapper, robot, targets.root[0])
    solver = placo.KinematicsSolver(wrapper)
    solver.mask_fbase(False)
    solver.enable_joint_limits(True)
    tasks = make_tasks(solver, wrapper, robot, points, config)
    ground = GroundGuard(solver, wrapper, robot, config.weights.contact_foot_position * 10)
    frames = len(targets.time)
    base, joints = np.empty((frames, 4, 4)), np.empty((frames, len(robot.joint_names)))
    for t in range(frames):
        for task in tasks:
            task.update(targets, t)
        iterations = config.settle_iterations if t == 0 else config.iterations
        if t == 1 and config.velocity_limits:
            # each solve may move at the limit for its share of the frame time
            solver.enable_velocity_limits(True)
            solver.dt = float(targets.time[1] - targets.time[0]) / iterations
        try:
            _solve_frame(solver, wrapper, tasks, ground, iterations)
        except RuntimeError as exc:  # PlaCo's QP errors
            raise RetargetError(f"frame {t}: the IK failed: {exc}") from None
        base[t] = wrapper.get_T_world_fbase()
        joints[t] = [wrapper.get_joint(name) for name in robot.joint_names]
        if progress is not None:
            progress(t)
    return base, joints


def _stand(wrapper: Any, robot: Robot, root: Array) -> None:
    """The robot in its standing posture with its root at pose `root` (4, 4)."""
    for name, value in robot.spec.posture_angles().items():
        wrapper.set_joint(name, value)
    wrapper.set_T_world_fbase(root)
    wrapper.update_kinematics()


def _solve_frame(
    solver: Any, wrapper: Any, tasks: list[Task], ground: GroundGuard, iterations: int
) -> None:
    """Solve one frame; while that leaves a sole corner below the ground, solve it again from
    the previous frame's pose with the corners held up."""
    previous = wrapper.state.q.copy()
    _solve(solver, wrapper, tasks, iterations)
    for _ in range(GroundGuard.ROUNDS):
        if not ground.engage():
            break
        wrapper.state.q = previous
        wrapper.update_kinematics()
        _solve(solver, wrapper, tasks, iterations)
    ground.release()


def _solve(solver: Any, wrapper: Any, tasks: list[Task], iterations: int) -> None:
    """`iterations` solves, each from where the last one left the robot."""
    for _ in range(iterations):
        for task in tasks:
            task.track()
        solver.solve(True)
        wrapper.update_kinematics()
