"""Per-frame PlaCo inverse kinematics over a whole motion, warm-started frame to frame."""

from __future__ import annotations

import contextlib
import hashlib
import json
import os
import sys
from collections.abc import Callable, Iterator
from itertools import combinations
from typing import Any

import numpy as np

from motionkit.errors import RetargetError
from motionkit.extras import require
from motionkit.retarget.bodies import avoided, capsules, host_link, with_collision_cylinders
from motionkit.retarget.config import RetargetConfig, Weights
from motionkit.retarget.points import Point
from motionkit.retarget.targets import SIDES, Targets
from motionkit.robot import Robot
from motionkit.robot.geometry import Array
from motionkit.robot.model import cached_file


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
    with _quiet():  # PlaCo prints every pair that touches at the zero pose
        wrapper = placo.RobotWrapper(str(cached_file(robot, f"capsules-{key}.urdf", text)), 0)
    wrapper.load_collision_pairs(str(cached_file(robot, f"pairs-{key}.json", json.dumps(pairs))))
    return wrapper


@contextlib.contextmanager
def _quiet() -> Iterator[None]:
    """Silence what C++ code writes to the process's stdout and stderr."""
    sys.stdout.flush()
    sys.stderr.flush()
    saved = [os.dup(1), os.dup(2)]
    try:
        with open(os.devnull, "wb") as null:
            os.dup2(null.fileno(), 1)
            os.dup2(null.fileno(), 2)
            yield
    finally:
        for fd, copy in zip((1, 2), saved, strict=True):
            os.dup2(copy, fd)
            os.close(copy)


def solve_motion(
    robot: Robot,
    targets: Targets,
    points: dict[str, Point],
    config: RetargetConfig,
    progress: Callable[[int], None] | None = None,
) -> tuple[Array, Array]:
    """Base poses (T, 4, 4) and joint positions (T, J) in spec order."""
    require("ik", "retargeting", RetargetError, ("placo",))
    import placo

    wrapper = _load_wrapper(placo, robot, points, config.self_collisions)
    for name, value in robot.spec.posture_angles().items():
        wrapper.set_joint(name, value)
    wrapper.set_T_world_fbase(targets.root[0])
    wrapper.update_kinematics()

    solver = placo.KinematicsSolver(wrapper)
    solver.mask_fbase(False)
    solver.enable_joint_limits(True)
    weights = config.weights
    root = solver.add_frame_task(robot.spec.root, targets.root[0])
    root.configure("pelvis", "soft", weights.pelvis_position, weights.pelvis_orientation)
    torso = solver.add_orientation_task(config.points.torso_frame, targets.torso[0])
    torso.configure("torso", "soft", weights.torso_orientation)
    feet, knees, elbows = [], [], []
    for k, foot in enumerate(robot.spec.feet):
        task = solver.add_frame_task(foot.sole, targets.soles[0, k])
        task.configure(foot.sole, "soft", weights.foot_position, weights.foot_orientation)
        feet.append(task)
        knees.append(_point_task(solver, points[f"{SIDES[k]}_knee"], targets.knees[0, k]))
        knees[-1].configure(f"knee {k}", "soft", weights.knee)
        elbows.append(_point_task(solver, points[f"{SIDES[k]}_elbow"], np.zeros(3)))
        elbows[-1].configure(f"elbow {k}", "soft", weights.elbow)
    if config.self_collisions:
        avoid = solver.add_avoid_self_collisions_constraint()
        avoid.self_collisions_margin = config.collision_margin
        avoid.self_collisions_trigger = config.collision_margin + 0.04
        avoid.configure("self collisions", "soft", 1e4)  # hard fails on clips that start inside
    posture = solver.add_joints_task()
    posture.set_joints(robot.spec.posture_angles())
    posture.configure("posture", "soft", weights.posture)

    shoulders = [points[f"{s}_shoulder"] for s in SIDES]
    ground = _GroundGuard(solver, wrapper, robot, weights.contact_foot_position * 10)

    def solve_frame(t: int, iterations: int) -> None:
        for _ in range(iterations):
            for k in range(2):  # the elbow goes along the human upper arm from the shoulder
                shoulder = _world(wrapper, shoulders[k])
                length = targets.upper_arm_length[k]
                elbows[k].target_world = shoulder + length * targets.upper_arms[t, k]
            solver.solve(True)
            wrapper.update_kinematics()

    landing = np.zeros((2, 3))  # per foot: x, y, yaw of the robot's sole minus the plan's
    frames = len(targets.time)
    base = np.empty((frames, 4, 4))
    joints = np.empty((frames, len(robot.joint_names)))
    for t in range(frames):
        root.T_world_frame = targets.root[t]
        torso.R_world_frame = targets.torso[t]
        for k, foot in enumerate(robot.spec.feet):
            if t > 0 and targets.contacts[t, k] and not targets.contacts[t - 1, k]:
                # a contact locks the sole where the robot's foot is, not where the plan put it
                actual = wrapper.get_T_world_frame(foot.sole)
                landing[k] = _planar_offset(actual, targets.soles[t, k])
            feet[k].T_world_frame = _shifted(targets.soles[t, k], targets.hold[t, k] * landing[k])
            feet[k].configure(foot.sole, "soft", *foot_weights(weights, targets.hold[t, k]))
            knees[k].target_world = targets.knees[t, k]
        if t == 0:
            iterations = config.settle_iterations
        else:
            iterations = config.iterations
            if config.velocity_limits and t == 1:
                # each solve may move at the limit for its share of the frame time
                solver.enable_velocity_limits(True)
                solver.dt = float(targets.time[1] - targets.time[0]) / iterations
        previous = wrapper.state.q.copy()
        try:
            solve_frame(t, iterations)
            for _ in range(_GroundGuard.ROUNDS):  # a corner went below: solve again, holding it up
                if not ground.engage():
                    break
                wrapper.state.q = previous
                wrapper.update_kinematics()
                solve_frame(t, iterations)
        except RuntimeError as exc:  # PlaCo's QP errors
            raise RetargetError(f"frame {t}: the IK failed: {exc}") from None
        ground.release()
        base[t] = wrapper.get_T_world_fbase()
        joints[t] = [wrapper.get_joint(name) for name in robot.joint_names]
        if progress is not None:
            progress(t)
    return base, joints


def foot_weights(weights: Weights, hold: float) -> tuple[float, float]:
    """Position and orientation weights of a sole task: the swing weights blended toward the
    contact ones by the hold weight (1 in contact), so that a planted foot wins over a swinging
    one that its leg's joint velocity limits hold back."""
    return (
        weights.foot_position + hold * (weights.contact_foot_position - weights.foot_position),
        weights.foot_orientation
        + hold * (weights.contact_foot_orientation - weights.foot_orientation),
    )


class _GroundGuard:
    """Holds sole corners on the ground plane (z = 0) when a solve pushed them below it: the
    frame is solved again with a height task on each such corner, and again while a corner is
    still below (the set grows; ROUNDS at most). PlaCo has no inequality task on a frame's
    height, hence this active-set step; it runs only on the frames that need it."""

    TOLERANCE = 5e-4  # m below the ground that is let pass
    ROUNDS = 3

    def __init__(self, solver: object, wrapper: object, robot: Robot, weight: float) -> None:
        self.solver, self.wrapper, self.weight = solver, wrapper, weight
        self.corners = [c for foot in robot.spec.feet for c in foot.corners]
        self.active: list[object] = []
        self.held: set[str] = set()

    def engage(self) -> bool:
        """Add a task for each corner newly below the ground; whether any was added."""
        added = False
        for corner in self.corners:
            if corner in self.held:
                continue
            position = self.wrapper.get_T_world_frame(corner)[:3, 3]  # type: ignore[attr-defined]
            if position[2] < -self.TOLERANCE:
                target = np.array([position[0], position[1], 0.0])
                task = self.solver.add_position_task(corner, target)  # type: ignore[attr-defined]
                task.mask.set_axises("z")
                task.configure(f"ground {corner}", "soft", self.weight)
                self.active.append(task)
                self.held.add(corner)
                added = True
        return added

    def release(self) -> None:
        for task in self.active:
            self.solver.remove_task(task)  # type: ignore[attr-defined]
        self.active.clear()
        self.held.clear()


def _planar_offset(actual: Array, planned: Array) -> Array:
    """x, y and yaw of pose `actual` relative to `planned` (world frame)."""
    relative = actual[:3, :3] @ planned[:3, :3].T
    yaw = np.arctan2(relative[1, 0], relative[0, 0])
    return np.array([*(actual[:2, 3] - planned[:2, 3]), yaw])


def _shifted(pose: Array, offset: Array) -> Array:
    """`pose` turned by offset[2] about the vertical through it and moved by offset[:2]."""
    c, s = np.cos(offset[2]), np.sin(offset[2])
    out = pose.copy()
    out[:2, :3] = np.array([[c, -s], [s, c]]) @ pose[:2, :3]
    out[:2, 3] += offset[:2]
    return out


def _point_task(solver: object, point: Point, target: Array) -> object:
    """A position task on a point fixed in a link (PlaCo tasks act on frame origins, so the
    target is shifted by the point's offset, expressed in the world at solve time)."""
    task = solver.add_position_task(point.link, target)  # type: ignore[attr-defined]
    if np.linalg.norm(point.offset) > 1e-9:
        raise RetargetError(
            f"an IK point must be a frame origin; '{point.link}' + {point.offset} is not"
        )
    return task


def _world(wrapper: object, point: Point) -> Array:
    pose = wrapper.get_T_world_frame(point.link)  # type: ignore[attr-defined]
    return pose[:3, :3] @ point.offset + pose[:3, 3]
