"""The IK's tasks on a PlaCo solver. Each is configured once, from the config and the robot, and
`update(targets, t)` sets its targets for frame t; one whose target follows the robot's own pose
(an elbow: along the human upper arm from the robot's shoulder) also `track`s it before each
solve. A sole in contact is a hard constraint (PlaCo holds it exactly) at its lock. The posture
and the self-collision constraint are fixed; the ground guard holds sole corners up on the
frames that pushed them below the ground."""

from __future__ import annotations

from itertools import zip_longest
from typing import Any

import numpy as np

from motionkit.core.errors import RetargetError
from motionkit.retarget.config import RetargetConfig, Weights
from motionkit.retarget.points import Point
from motionkit.retarget.targets import SIDES, Targets
from motionkit.robot import Robot
from motionkit.robot.geometry import Array
from motionkit.robot.spec import FootSpec


class Task:
    """A soft task whose targets change from frame to frame."""

    def update(self, targets: Targets, t: int) -> None:
        """Set the targets of frame `t`."""

    def track(self) -> None:
        """Before each solve: move a target that follows the robot's current pose."""

    def settled(self) -> bool:
        """After the first frame's solve from the standing posture: whether the task changed
        (and the frame is to be solved again)."""
        return False


class RootTask(Task):
    """The root link's pose follows the human pelvis."""

    def __init__(self, solver: Any, robot: Robot, weights: Weights) -> None:
        self.task = solver.add_frame_task(robot.spec.root, np.eye(4))
        self.task.configure("pelvis", "soft", weights.pelvis_position, weights.pelvis_orientation)

    def update(self, targets: Targets, t: int) -> None:
        self.task.T_world_frame = targets.root[t]


class TorsoTask(Task):
    """The torso frame's orientation follows the human chest."""

    def __init__(self, solver: Any, frame: str, weights: Weights) -> None:
        self.task = solver.add_orientation_task(frame, np.eye(3))
        self.task.configure("torso", "soft", weights.torso_orientation)

    def update(self, targets: Targets, t: int) -> None:
        self.task.R_world_frame = targets.torso[t]


class FootTask(Task):
    """Sole `index` of the targets.

    A contact locks the sole where the robot's foot is when it lands, not where the plan put
    it: the landing offset (x, y, yaw of the robot's sole, as the previous frame left it, minus
    the plan's) applies while the hold weight lasts, and the weights rise to the contact ones
    with it. With `hard`, a sole in contact is a hard constraint at its lock (the plan's sole
    shifted by the landing offset at touchdown, flat on the ground, kept for the whole
    contact); a contact in the first frame becomes hard once that frame has settled from the
    standing posture (a hard constraint far from the robot's pose could ask more than its
    joint limits allow)."""

    def __init__(
        self,
        solver: Any,
        wrapper: Any,
        foot: FootSpec,
        index: int,
        weights: Weights,
        hard: bool = True,
    ) -> None:
        self.wrapper, self.sole, self.index, self.weights = wrapper, foot.sole, index, weights
        self.hard = hard
        self.task = solver.add_frame_task(foot.sole, np.eye(4))
        self.landing = np.zeros(3)
        self.lock: Array | None = None  # the pose held in the current contact
        self.pending: Array | None = None  # the first frame's, until it has settled

    def update(self, targets: Targets, t: int) -> None:
        k, plan = self.index, targets.soles[t, self.index]
        contact = bool(targets.contacts[t, k])
        if not contact or (t > 0 and not targets.contacts[t - 1, k]):
            self.lock = None
        if contact and t > 0 and not targets.contacts[t - 1, k]:
            self.landing = _planar_offset(self.wrapper.get_T_world_frame(self.sole), plan)
        hold = targets.hold[t, k]
        target = _shifted(plan, hold * self.landing)
        self.pending = target if self.hard and contact and t == 0 else None
        if self.hard and contact and t > 0:
            if self.lock is None:
                self.lock = target
            self._hold(self.lock)
        else:
            self.task.T_world_frame = target
            self.task.configure(self.sole, "soft", *foot_weights(self.weights, hold))

    def settled(self) -> bool:
        if self.pending is None:
            return False
        self.lock, self.pending = self.pending, None
        self._hold(self.lock)
        return True

    def _hold(self, pose: Array) -> None:
        self.task.T_world_frame = pose
        self.task.configure(self.sole, "hard")


class KneeTask(Task):
    """The knee of human side `index` (l, r) at its rebuilt position."""

    def __init__(self, solver: Any, point: Point, index: int, weight: float) -> None:
        self.task, self.index = _point_task(solver, point), index
        self.task.configure(f"knee {index}", "soft", weight)

    def update(self, targets: Targets, t: int) -> None:
        self.task.target_world = targets.knees[t, self.index]


class ElbowTask(Task):
    """The elbow of human side `index` (l, r) along the human upper arm from the robot's
    shoulder, at the robot's upper-arm length."""

    def __init__(
        self, solver: Any, wrapper: Any, shoulder: Point, elbow: Point, index: int, weight: float
    ) -> None:
        self.wrapper, self.shoulder, self.index = wrapper, shoulder, index
        self.task = _point_task(solver, elbow)
        self.task.configure(f"elbow {index}", "soft", weight)
        self.reach = np.zeros(3)  # shoulder to elbow [m]

    def update(self, targets: Targets, t: int) -> None:
        self.reach = targets.upper_arm_length[self.index] * targets.upper_arms[t, self.index]

    def track(self) -> None:
        self.task.target_world = _world(self.wrapper, self.shoulder) + self.reach


def make_tasks(
    solver: Any, wrapper: Any, robot: Robot, points: dict[str, Point], config: RetargetConfig
) -> list[Task]:
    """The tasks of the retargeting on `solver`: root, torso, one per foot of the robot's spec,
    knees and elbows of both human sides; with the fixed self-collision and posture ones."""
    weights = config.weights
    tasks: list[Task] = [
        RootTask(solver, robot, weights),
        TorsoTask(solver, config.points.torso_frame, weights),
    ]
    # Made foot, knee, elbow per side: PlaCo sums its tasks in the order of their addresses,
    # and another order rounds differently (each frame solved to convergence keeps that at the
    # size of the rounding; two solves a frame once amplified it to 1e-3 rad).
    for k, (foot, side) in enumerate(zip_longest(robot.spec.feet, SIDES)):
        if foot is not None:
            tasks.append(FootTask(solver, wrapper, foot, k, weights, config.hard_contacts))
        if side is not None:
            shoulder, elbow = points[f"{side}_shoulder"], points[f"{side}_elbow"]
            tasks.append(KneeTask(solver, points[f"{side}_knee"], k, weights.knee))
            tasks.append(ElbowTask(solver, wrapper, shoulder, elbow, k, weights.elbow))
    if config.self_collisions:
        avoid = solver.add_avoid_self_collisions_constraint()
        avoid.self_collisions_margin = config.collision_margin
        avoid.self_collisions_trigger = config.collision_margin + 0.04
        avoid.configure("self collisions", "soft", 1e4)  # hard fails on clips that start inside
    posture = solver.add_joints_task()
    posture.set_joints(robot.spec.posture_angles())
    posture.configure("posture", "soft", weights.posture)
    return tasks


def foot_weights(weights: Weights, hold: float) -> tuple[float, float]:
    """Position and orientation weights of a sole task: the swing weights blended toward the
    contact ones by the hold weight (1 in contact), so that a planted foot wins over a swinging
    one that its leg's joint velocity limits hold back."""
    return (
        weights.foot_position + hold * (weights.contact_foot_position - weights.foot_position),
        weights.foot_orientation
        + hold * (weights.contact_foot_orientation - weights.foot_orientation),
    )


class GroundGuard:
    """Holds sole corners on the ground plane (z = 0) when a solve pushed them below it: the
    frame is solved again with a height task on each such corner, and again while a corner is
    still below (the set grows; ROUNDS at most). PlaCo has no inequality task on a frame's
    height, hence this active-set step; it runs only on the frames that need it."""

    TOLERANCE = 5e-4  # m below the ground that is let pass
    ROUNDS = 3

    def __init__(self, solver: Any, wrapper: Any, robot: Robot, weight: float) -> None:
        self.solver, self.wrapper, self.weight = solver, wrapper, weight
        self.corners = [c for foot in robot.spec.feet for c in foot.corners]
        self.active: list[Any] = []
        self.held: set[str] = set()

    def engage(self) -> bool:
        """Add a task for each corner newly below the ground; whether any was added."""
        added = False
        for corner in self.corners:
            if corner in self.held:
                continue
            position = self.wrapper.get_T_world_frame(corner)[:3, 3]
            if position[2] < -self.TOLERANCE:
                target = np.array([position[0], position[1], 0.0])
                task = self.solver.add_position_task(corner, target)
                task.mask.set_axises("z")
                task.configure(f"ground {corner}", "soft", self.weight)
                self.active.append(task)
                self.held.add(corner)
                added = True
        return added

    def release(self) -> None:
        """Remove the corner tasks."""
        for task in self.active:
            self.solver.remove_task(task)
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


def _point_task(solver: Any, point: Point) -> Any:
    """A position task on a point fixed in a link; PlaCo's act on frame origins, so the point
    must be one."""
    if np.linalg.norm(point.offset) > 1e-9:
        raise RetargetError(
            f"an IK point must be a frame origin; '{point.link}' + {point.offset} is not"
        )
    return solver.add_position_task(point.link, np.zeros(3))


def _world(wrapper: Any, point: Point) -> Array:
    """The world position [m] of `point` at the robot's current pose."""
    pose = wrapper.get_T_world_frame(point.link)
    return pose[:3, :3] @ point.offset + pose[:3, 3]
