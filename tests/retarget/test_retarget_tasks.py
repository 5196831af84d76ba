"""The IK's tasks on a stand-in solver (no PlaCo): one foot task per foot of the spec, in the
order PlaCo was always given them; targets set per frame by hand-computed values; the landing
lock, the elbow that follows the shoulder, the ground guard's corner tasks."""

from dataclasses import replace
from types import SimpleNamespace
from typing import Any

import numpy as np
import pytest

from motionkit.core.errors import RetargetError
from motionkit.retarget.config import RetargetConfig
from motionkit.retarget.points import Point, robot_points
from motionkit.retarget.targets import Targets
from motionkit.retarget.tasks import ElbowTask, FootTask, GroundGuard, make_tasks
from motionkit.robot import ironcub
from motionkit.robot.spec import FootSpec


class FakeTask(SimpleNamespace):
    def configure(self, name: str, priority: str, *weights: float) -> None:
        self.name, self.priority, self.weights = name, priority, weights

    def set_joints(self, angles: dict[str, float]) -> None:
        self.joints = angles


class FakeSolver:
    """Logs the tasks made, in order."""

    def __init__(self) -> None:
        self.made: list[FakeTask] = []
        self.removed: list[FakeTask] = []

    def _add(self, kind: str, frame: str | None = None, target: Any = None) -> FakeTask:
        self.made.append(FakeTask(kind=kind, frame=frame, target=target))
        return self.made[-1]

    def add_frame_task(self, frame: str, pose: np.ndarray) -> FakeTask:
        return self._add("frame", frame)

    def add_orientation_task(self, frame: str, rotation: np.ndarray) -> FakeTask:
        return self._add("orientation", frame)

    def add_position_task(self, frame: str, target: np.ndarray) -> FakeTask:
        task = self._add("position", frame, target)
        task.mask = SimpleNamespace(set_axises=lambda axes: setattr(task, "axes", axes))
        return task

    def add_avoid_self_collisions_constraint(self) -> FakeTask:
        return self._add("avoid")

    def add_joints_task(self) -> FakeTask:
        return self._add("joints")

    def remove_task(self, task: FakeTask) -> None:
        self.removed.append(task)


class FakeWrapper:
    """Frame poses as given."""

    def __init__(self, poses: dict[str, np.ndarray]) -> None:
        self.poses = poses

    def get_T_world_frame(self, frame: str) -> np.ndarray:
        return self.poses[frame]


def _pose(x: float, y: float, z: float, yaw: float = 0.0) -> np.ndarray:
    c, s = np.cos(yaw), np.sin(yaw)
    pose = np.eye(4)
    pose[:3, :3] = [[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]
    pose[:3, 3] = x, y, z
    return pose


def _targets(frames: int, feet: int) -> Targets:
    """Targets at rest: identity poses, no contact."""
    return Targets(
        time=np.arange(frames) / 100.0,
        scale=1.0,
        contacts=np.zeros((frames, feet), dtype=bool),
        root=np.tile(np.eye(4), (frames, 1, 1)),
        torso=np.tile(np.eye(3), (frames, 1, 1)),
        soles=np.tile(np.eye(4), (frames, feet, 1, 1)),
        hold=np.zeros((frames, feet)),
        knees=np.zeros((frames, 2, 3)),
        upper_arms=np.zeros((frames, 2, 3)),
        upper_arm_length=np.zeros(2),
        source_slide=np.zeros(0),
        human={},
    )


def test_one_foot_task_per_spec_foot_in_the_order_placo_had() -> None:
    robot, config = ironcub(), RetargetConfig()
    tail = FootSpec("tail", "tail_sole", ("tail_1",))
    spec = replace(robot.spec, feet=(*robot.spec.feet, tail))
    points, solver = robot_points(robot, config.points), FakeSolver()
    tasks = make_tasks(solver, None, SimpleNamespace(spec=spec), points, config)
    limbs = {name: point.link for name, point in points.items()}
    assert [task.frame for task in solver.made] == [
        spec.root, "chest",
        "l_sole", limbs["l_knee"], limbs["l_elbow"],
        "r_sole", limbs["r_knee"], limbs["r_elbow"],
        "tail_sole",
        None, None,  # self collisions, posture
    ]  # fmt: skip
    assert len(tasks) == 2 + 3 + 2 * 2  # the fixed two are not updated per frame
    assert solver.made[3].weights == (config.weights.knee,)
    assert solver.made[-1].joints == spec.posture_angles()


def _landing_plan(frames: int) -> Targets:
    """One sole walked along x by 0.1 m a frame by the plan, in contact on frames 1 and 2,
    its hold weight 1 there and 0.5 on frame 3."""
    targets = _targets(frames, 1)
    targets.soles[:, 0] = [_pose(0.1 * t, 0.0, 0.0) for t in range(frames)]
    targets.contacts[1:3, 0] = True
    targets.hold[1:3, 0] = 1.0
    targets.hold[3, 0] = 0.5
    return targets


def test_foot_locks_where_the_robot_landed() -> None:
    """The plan lands the sole at frame 1; the robot's sole is then at (0.12, 0.03), turned
    0.1 rad (the landing offset (0.02, 0.03, 0.1)). The contact holds it there, a hard
    constraint, also on frame 2 where the plan has moved on to x = 0.2 and the robot's sole
    is elsewhere; on frame 3 the contact is over and half of the offset applies to the plan's
    (0.3, 0): (0.31, 0.015), yaw 0.05, soft with the weights half way to the contact ones."""
    weights = RetargetConfig().weights
    targets = _landing_plan(4)
    wrapper = FakeWrapper({"sole": _pose(0.12, 0.03, 0.0, 0.1)})
    foot = FootTask(FakeSolver(), wrapper, FootSpec("left", "sole", ("c",)), 0, weights)
    foot.update(targets, 0)
    np.testing.assert_array_equal(foot.task.T_world_frame, targets.soles[0, 0])
    assert foot.task.priority == "soft"
    assert foot.task.weights == (weights.foot_position, weights.foot_orientation)
    foot.update(targets, 1)
    lock = foot.task.T_world_frame
    np.testing.assert_allclose(lock, _pose(0.12, 0.03, 0.0, 0.1), atol=1e-15)
    assert (foot.task.priority, foot.task.weights) == ("hard", ())
    wrapper.poses["sole"] = _pose(0.5, 0.5, 0.0)  # no landing: the lock stays
    foot.update(targets, 2)
    np.testing.assert_array_equal(foot.task.T_world_frame, lock)
    assert foot.task.priority == "hard"
    foot.update(targets, 3)
    np.testing.assert_allclose(foot.task.T_world_frame, _pose(0.31, 0.015, 0.0, 0.05), atol=1e-15)
    assert foot.task.priority == "soft"
    assert foot.task.weights == pytest.approx((50500.0, 5050.0))


def test_a_soft_contact_follows_the_plan_shifted_by_the_landing() -> None:
    """hard_contacts off: on frame 2 the sole task is the plan's (0.2, 0) shifted by the
    landing offset, (0.22, 0.03), yaw 0.1, with the contact weights."""
    weights = RetargetConfig().weights
    targets = _landing_plan(4)
    wrapper = FakeWrapper({"sole": _pose(0.12, 0.03, 0.0, 0.1)})
    foot = FootTask(FakeSolver(), wrapper, FootSpec("left", "sole", ("c",)), 0, weights, False)
    for t in range(3):
        foot.update(targets, t)
    np.testing.assert_allclose(foot.task.T_world_frame, _pose(0.22, 0.03, 0.0, 0.1), atol=1e-15)
    assert foot.task.priority == "soft"
    assert foot.task.weights == (weights.contact_foot_position, weights.contact_foot_orientation)
    assert not foot.settled()


def test_a_first_frame_contact_turns_hard_once_settled() -> None:
    """A contact from frame 0: soft while the robot settles from its standing posture, then
    held hard where the plan put it (the robot's standing sole is no landing); a foot in
    the air at frame 0 stays as it is."""
    weights = RetargetConfig().weights
    targets = _landing_plan(4)
    targets.contacts[0, 0] = True
    targets.hold[0, 0] = 1.0
    wrapper = FakeWrapper({"sole": _pose(0.5, 0.5, 0.0)})
    foot = FootTask(FakeSolver(), wrapper, FootSpec("left", "sole", ("c",)), 0, weights)
    foot.update(targets, 0)
    assert foot.task.priority == "soft"
    assert foot.settled() and not foot.settled()
    assert foot.task.priority == "hard"
    np.testing.assert_array_equal(foot.task.T_world_frame, targets.soles[0, 0])
    foot.update(targets, 1)
    np.testing.assert_array_equal(foot.task.T_world_frame, targets.soles[0, 0])
    assert foot.task.priority == "hard"
    targets.contacts[0, 0] = False
    foot.update(targets, 0)
    assert not foot.settled() and foot.task.priority == "soft"


def test_elbow_follows_the_shoulder_along_the_human_upper_arm() -> None:
    """Shoulder 0.1 m along x of a link at (0, 0, 1) turned 90 degrees: at (0, 0.1, 1); the
    arm hangs 0.2 m straight down from it."""
    targets = replace(_targets(1, 2), upper_arm_length=np.array([0.3, 0.2]))
    targets.upper_arms[0, 1] = [0.0, 0.0, -1.0]
    wrapper = FakeWrapper({"arm": _pose(0.0, 0.0, 1.0, np.pi / 2)})
    shoulder, elbow = Point("arm", np.array([0.1, 0.0, 0.0])), Point("forearm", np.zeros(3))
    task = ElbowTask(FakeSolver(), wrapper, shoulder, elbow, 1, 0.5)
    task.update(targets, 0)
    task.track()
    np.testing.assert_allclose(task.task.target_world, [0.0, 0.1, 0.8], atol=1e-15)
    assert task.task.weights == (0.5,)
    with pytest.raises(RetargetError, match="frame origin"):
        ElbowTask(FakeSolver(), wrapper, shoulder, shoulder, 1, 0.5)


def test_ground_guard_holds_the_corners_below_the_ground() -> None:
    """A corner 1 mm below is held up at its x, y; one 0.1 mm below is let pass."""
    robot = ironcub()
    corners = [c for foot in robot.spec.feet for c in foot.corners]
    poses = {c: _pose(0.0, 0.0, 0.01) for c in corners}
    poses[corners[0]] = _pose(0.1, 0.2, -1e-3)
    poses[corners[-1]] = _pose(0.3, 0.4, -1e-4)
    solver = FakeSolver()
    guard = GroundGuard(solver, FakeWrapper(poses), robot, 1e6)
    assert guard.engage()
    assert not guard.engage()  # held already; nothing new below
    (task,) = solver.made
    assert (task.frame, task.axes, task.weights) == (corners[0], "z", (1e6,))
    np.testing.assert_array_equal(task.target, [0.1, 0.2, 0.0])
    guard.release()
    assert solver.removed == [task] and not guard.held
