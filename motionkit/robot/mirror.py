"""The robot's left-right mirror: the reflection through its sagittal plane, as maps of joints,
jets, feet and end effectors, and of base-frame vectors, angular velocities and orientations.

Pairs are found by name: a name whose "_"-separated parts hold "l" or "left" pairs with the
name that has "r" or "right" there (l_hip_roll / r_hip_roll, chest_left / chest_right); a name
with neither is its own mirror (torso_roll). A joint's sign comes from the model: mirrored, a
rotation about axis a is one about -M a (M the reflection, a an axial vector), so the partner's
angle is +q where its axis is -M a at the zero pose and -q where it is +M a (torso_roll, yaw).

The plane holds the robot's up axis (z) and its forward axis (`spec.forward`), in the base
frame at the identity orientation, which is also the world frame of heading-free features.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import TYPE_CHECKING

import mujoco
import numpy as np

from motionkit.core.errors import RobotModelError
from motionkit.robot.model import Robot

if TYPE_CHECKING:
    from motionkit.dataset.trajectory import Trajectory

SIDES = {"l": "r", "r": "l", "left": "right", "right": "left"}
ALIGNED = 0.99  # |cos| between mirrored axes that counts as the same axis


@dataclass(frozen=True)
class Mirror:
    """Index maps (the partner of each item) and signs of the mirror, and its plane's normal."""

    normal: np.ndarray  # (3,) unit vector across the sagittal plane, base frame
    joints: np.ndarray  # (J,) index of each joint's partner
    joint_signs: np.ndarray  # (J,) +1 or -1
    jets: np.ndarray
    feet: np.ndarray
    effectors: np.ndarray

    @property
    def reflection(self) -> np.ndarray:
        """M = I - 2 n n^T (3, 3)."""
        return np.eye(3) - 2.0 * np.outer(self.normal, self.normal)

    def vector(self, v: np.ndarray) -> np.ndarray:
        """A polar vector (..., 3): a position, a linear velocity, a force."""
        return v @ self.reflection.T

    def axial(self, w: np.ndarray) -> np.ndarray:
        """An axial vector (..., 3): an angular velocity, a rotation axis."""
        return -self.vector(w)

    def quaternion(self, q: np.ndarray) -> np.ndarray:
        """An orientation wxyz (..., 4) of the base in a frame mirrored through the same plane:
        M R M is the rotation by the same angle about -M a, i.e. (w, -M v)."""
        return np.concatenate([q[..., :1], self.axial(q[..., 1:])], axis=-1)

    def joint_values(self, q: np.ndarray) -> np.ndarray:
        """Joint positions, velocities or targets (..., J)."""
        return q[..., self.joints] * self.joint_signs


def mirror_name(name: str) -> str:
    """The name with its side swapped (itself when it names no side)."""
    return "_".join(SIDES.get(part, part) for part in name.split("_"))


def partners(names: tuple[str, ...] | list[str], what: str) -> np.ndarray:
    """For each name, the index of its mirror among `names`; RobotModelError if one is missing."""
    index = {name: i for i, name in enumerate(names)}
    missing = [n for n in names if mirror_name(n) not in index]
    if missing:
        raise RobotModelError(
            f"no mirror for {what} {missing} (expected {[mirror_name(n) for n in missing]})"
        )
    return np.array([index[mirror_name(n)] for n in names], dtype=np.int64)


def robot_mirror(robot: Robot) -> Mirror:
    """The mirror of a robot from its joint, jet, foot and end-effector names and its MJCF's
    joint axes at the zero pose. RobotModelError names what has no mirror."""
    spec = robot.spec
    forward = np.asarray(spec.forward, float)
    normal = np.cross([0.0, 0.0, 1.0], forward)
    normal /= np.linalg.norm(normal)
    joints = partners(robot.joint_names, "joints")
    mirror = Mirror(
        normal=normal,
        joints=joints,
        joint_signs=np.ones(len(joints)),
        jets=partners([jet.name for jet in spec.jets], "jets"),
        feet=partners([foot.sole for foot in spec.feet], "feet"),
        effectors=partners(list(spec.end_effectors), "end effectors"),
    )
    axes = _joint_axes(robot)
    signs = np.array([np.dot(axes[joints[i]], mirror.axial(a)) for i, a in enumerate(axes)])
    if np.any(np.abs(signs) < ALIGNED):
        odd = [robot.joint_names[i] for i in np.flatnonzero(np.abs(signs) < ALIGNED)]
        raise RobotModelError(f"joints {odd}: their partners' axes are not their mirror images")
    return Mirror(normal, joints, np.sign(signs), mirror.jets, mirror.feet, mirror.effectors)


def _joint_axes(robot: Robot) -> np.ndarray:
    """(J, 3) each joint's axis in the base frame at the zero pose (base at the identity)."""
    model = mujoco.MjModel.from_xml_string(robot.mjcf_text)
    data = mujoco.MjData(model)
    mujoco.mj_kinematics(model, data)
    base = data.xmat[model.body(robot.spec.root).id].reshape(3, 3)
    return np.array([base.T @ data.xaxis[model.joint(n).id] for n in robot.joint_names])


def mirror_trajectory(clip: Trajectory, mirror: Mirror) -> Trajectory:
    """The clip mirrored through the world plane of the mirror's normal (the clip's world axes
    taken as the base's at the identity): base pose and velocities (angular ones axial, in the
    world frame), joints, thrust, throttle and foot contacts; contact forces and the human
    landmarks are left out. Its metadata is the clip's."""
    q = clip.base_orientation.astype(float)
    return replace(
        clip,
        base_position=mirror.vector(clip.base_position),
        base_orientation=mirror.quaternion(q),
        joint_positions=mirror.joint_values(clip.joint_positions),
        joint_velocities=mirror.joint_values(clip.joint_velocities),
        base_linear_velocity=mirror.vector(clip.base_linear_velocity),
        base_angular_velocity=mirror.axial(clip.base_angular_velocity),
        thrust=clip.thrust[:, mirror.jets],
        throttle=None if clip.throttle is None else clip.throttle[:, mirror.jets],
        contacts=clip.contacts[:, mirror.feet],
        contact_forces=None,
        corner_names=(),
        landmarks=None,
        landmark_names=(),
        landmark_parents=(),
    )
