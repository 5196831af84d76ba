"""Robot points matched to human joints: hip and shoulder centres, knees, ankles, elbows."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from motionkit.core.errors import RetargetError
from motionkit.retarget.config import RobotPoints
from motionkit.robot import Robot
from motionkit.robot.geometry import Array, invert
from motionkit.robot.urdf import RobotModel

LIMBS = ("hip", "knee", "ankle", "shoulder", "elbow")


@dataclass(frozen=True)
class Point:
    """A point fixed in a link: `offset` [m] in the `link` frame."""

    link: str
    offset: Array


def meeting_point(model: RobotModel, joints: list[str]) -> Point:
    """The point where the joints' axes meet (least squares), fixed in the parent link of the
    first joint; for one joint, the origin of its child frame (a point on its axis)."""
    missing = [j for j in joints if j not in model.joints]
    if missing:
        raise RetargetError(
            f"{model.source}: no joint named {', '.join(missing)} (name the robot's own in the "
            "recipe's [points] table)"
        )
    first = model.joints[joints[0]]
    if len(joints) == 1:
        return Point(first.child, np.zeros(3))
    poses = model.link_poses()
    system, rhs = np.zeros((3, 3)), np.zeros(3)
    for name in joints:
        joint = model.joints[name]
        origin = poses[joint.child][:3, 3]
        axis = poses[joint.child][:3, :3] @ joint.axis
        projector = np.eye(3) - np.outer(axis, axis)
        system += projector
        rhs += projector @ origin
    world = np.linalg.lstsq(system, rhs, rcond=None)[0]
    local = invert(poses[first.parent]) @ np.append(world, 1.0)
    return Point(first.parent, local[:3])


def robot_points(robot: Robot, config: RobotPoints) -> dict[str, Point]:
    """'l_hip', 'r_knee', ... for the robot, from the joint groups of the config."""
    points = {}
    for side, prefix in zip(("l", "r"), config.sides, strict=True):
        for limb in LIMBS:
            joints = [j.format(s=prefix) for j in getattr(config, limb)]
            points[f"{side}_{limb}"] = meeting_point(robot.model, joints)
    return points
