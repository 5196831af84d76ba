"""Per-frame PlaCo inverse kinematics over a whole motion, warm-started frame to frame.

Each frame is solved to convergence: PlaCo's solve is one linearised step (a QP), so it is
repeated until the step is below the config's tolerance. Two steps a frame (as this once did)
left joints about 1e-3 rad from the frame's solution, an error that each frame passed on to the
next; rounding, which differs from CPU to CPU, then decided where a clip ended up (3 mrad apart
on two machines). A converged frame depends on the previous one only through the velocity
limits, so rounding stays at its own size. A step that reverses the previous one is taken
halfway: near a straight knee the linearisation overshoots, and full steps would go back and
forth. Joint velocity limits bound each frame's move from the previous frame's pose (a
joint-space box, hard), not each step's, so that they mean the same whatever the step count.
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Callable
from dataclasses import dataclass
from itertools import combinations
from typing import Any

import numpy as np

from motionkit.core.errors import RetargetError
from motionkit.core.extras import require
from motionkit.retarget.bodies import avoided, capsule_urdf, capsules, host_link
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
    """PlaCo's robot; with `avoid`, its collision model is the capsules of `bodies`, and the
    non-adjacent pairs with a jet or an upper arm in them are checked. Leg against leg is left
    to the metrics: the human's stance foot passes close to the swing leg, and pushing the legs
    apart would drag the locked foot."""
    if not avoid:
        return placo.RobotWrapper(kinematic_urdf(robot), placo.Flags.ignore_collisions)
    shapes, adjacent = capsules(robot, points)
    text = capsule_urdf(robot.model, shapes, f"{robot.name} with capsules")
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


@dataclass(frozen=True)
class Solution:
    """A solved motion, and how each frame's solve went."""

    base: Array  # (T, 4, 4) base poses, world frame [m]
    joints: Array  # (T, J) joint positions [rad], spec order
    iterations: Array  # (T,) PlaCo solves of each frame (with the ground guard's)
    converged: Array  # (T,) bool: the frame's last step was below the tolerance

    def figures(self) -> dict[str, float | int]:
        """The convergence figures of a clip's metrics."""
        return {
            "ik_iterations_mean": round(float(self.iterations.mean()), 2),
            "ik_iterations_max": int(self.iterations.max()),
            "ik_unconverged_frames": int((~self.converged).sum()),
        }


def solve_motion(
    robot: Robot,
    targets: Targets,
    points: dict[str, Point],
    config: RetargetConfig,
    progress: Callable[[int], None] | None = None,
) -> Solution:
    """The robot's motion that follows the targets, frame by frame, each solved to convergence
    from the last (the first frame settles from the standing posture).

    Args:
        robot: the robot; its spec names the root, the feet and the standing posture.
        targets: per-frame IK targets (T frames, world frame, m; see `Targets`).
        points: the robot points matched to the human's ('l_knee', ...; `robot_points`).
        config: the retargeting config (weights, tolerance, iterations, limits, contacts).
        progress: called with each frame's index once it is solved.

    Returns:
        Base poses (T, 4, 4) (world frame, m), joint positions (T, J) [rad] in spec order, and
        the solves each frame took.
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
    box = VelocityBox(solver, wrapper, robot) if config.velocity_limits else None
    frames = len(targets.time)
    base, joints = np.empty((frames, 4, 4)), np.empty((frames, len(robot.joint_names)))
    iterations, converged = np.zeros(frames, dtype=int), np.zeros(frames, dtype=bool)
    for t in range(frames):
        for task in tasks:
            task.update(targets, t)
        if t > 0 and box is not None:
            box.around(wrapper.state.q, float(targets.time[t] - targets.time[t - 1]))
        limit = config.settle_iterations if t == 0 else config.iterations
        try:
            used, size = _solve_frame(solver, wrapper, tasks, ground, limit, config.tolerance)
            changed = [task.settled() for task in tasks] if t == 0 else []  # all of them
            if any(changed):  # contacts of the first frame made hard: solved again
                more, size = _solve_frame(solver, wrapper, tasks, ground, limit, config.tolerance)
                used += more
        except RuntimeError as exc:  # PlaCo's QP errors
            raise RetargetError(f"frame {t}: the IK failed: {exc}") from None
        iterations[t], converged[t] = used, size < config.tolerance
        base[t] = wrapper.get_T_world_fbase()
        joints[t] = [wrapper.get_joint(name) for name in robot.joint_names]
        if progress is not None:
            progress(t)
    return Solution(base, joints, iterations, converged)


class VelocityBox:
    """Joint velocity limits over a frame: each joint within its limit times the frame time of
    where the previous frame left it (a hard joint-space constraint, A q <= b)."""

    def __init__(self, solver: Any, wrapper: Any, robot: Robot) -> None:
        self.solver = solver
        self.index = np.array([wrapper.get_joint_offset(name) for name in robot.joint_names])
        count = len(self.index)
        self.matrix = np.zeros((2 * count, wrapper.model.nq))
        self.matrix[np.arange(count), self.index] = 1.0
        self.matrix[count + np.arange(count), self.index] = -1.0
        self.speed = np.asarray(robot.limits.velocity, dtype=float)
        self.constraint: Any = None

    def bounds(self, q: Array, dt: float) -> Array:
        """b of A q <= b: q_j <= q0_j + v_j dt and -q_j <= -(q0_j - v_j dt), from the
        configuration `q` (PlaCo's, with the floating base first) and the frame time [s]."""
        now = q[self.index]
        return np.concatenate([now + self.speed * dt, -(now - self.speed * dt)])

    def around(self, q: Array, dt: float) -> None:
        """Limit the next frame's joints to those reachable from `q` in `dt` seconds."""
        if self.constraint is None:
            self.constraint = self.solver.add_joint_space_half_spaces_constraint(
                self.matrix, self.bounds(q, dt)
            )
            self.constraint.configure("velocity limits", "hard", 1.0)
        else:
            self.constraint.b = self.bounds(q, dt)


def _stand(wrapper: Any, robot: Robot, root: Array) -> None:
    """The robot in its standing posture with its root at pose `root` (4, 4)."""
    for name, value in robot.spec.posture_angles().items():
        wrapper.set_joint(name, value)
    wrapper.set_T_world_fbase(root)
    wrapper.update_kinematics()


def _solve_frame(
    solver: Any,
    wrapper: Any,
    tasks: list[Task],
    ground: GroundGuard,
    limit: int,
    tolerance: float,
) -> tuple[int, float]:
    """Solve one frame; while that leaves a sole corner below the ground, solve it again from
    the previous frame's pose with the corners held up. The solves made, and the largest
    component of the last step."""
    previous = wrapper.state.q.copy()
    used, size = converge(solver, wrapper, tasks, limit, tolerance)
    for _ in range(GroundGuard.ROUNDS):
        if not ground.engage():
            break
        wrapper.state.q = previous
        wrapper.update_kinematics()
        more, size = converge(solver, wrapper, tasks, limit, tolerance)
        used += more
    ground.release()
    return used, size


def converge(
    solver: Any, wrapper: Any, tasks: list[Task], limit: int, tolerance: float
) -> tuple[int, float]:
    """Solve from where the last solve left the robot until a step's largest component (rad,
    m) is below `tolerance`, at most `limit` times. Only a share of each step is taken: a step
    that goes back along the one before by more than half of it halves the share, one that
    goes on in its direction (a positive dot product) gives back half again, up to all of it.
    Steps that swing to and fro (a linearisation that overshoots, near a straight knee) shrink
    until they settle; steady ones are taken whole. The solves made and the last step's
    size."""
    import pinocchio

    last: Array | None = None
    share, size = 1.0, np.inf
    for n in range(1, limit + 1):
        for task in tasks:
            task.track()
        step = solver.solve(False)
        if last is not None:
            if _swings(step, last):
                share = 0.5 * share
            elif float(step @ last) > 0.0:
                share = min(1.0, 1.5 * share)
        step = share * step
        wrapper.state.q = pinocchio.integrate(wrapper.model, wrapper.state.q, step)
        wrapper.update_kinematics()
        size = float(np.abs(step).max())
        if size < tolerance:
            return n, size
        last = step
    return limit, size


def _swings(step: Array, last: Array) -> bool:
    """Whether `step` goes back along `last` by more than half of it: the iterations swing
    rather than settle."""
    return float(step @ last) < -0.5 * float(last @ last)
