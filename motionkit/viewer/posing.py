"""World poses of a robot's links for one frame, fast enough to run at every displayed frame.

The tree is flattened once (parent index, origin, axis and joint column per link); a frame is
then one vectorised Rodrigues for the movable joints and one 4x4 product per link.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from motionkit.robot import Robot
from motionkit.robot.geometry import Array


class LinkPoser:
    """Link poses (world frame) of `robot` from a base pose and joint positions."""

    def __init__(self, robot: Robot, joint_names: Sequence[str] | None = None) -> None:
        model = robot.model
        self.links: tuple[str, ...] = tuple(model.subtree(model.root))  # parents first
        self.index = {name: i for i, name in enumerate(self.links)}
        column = {name: i for i, name in enumerate(joint_names or robot.joint_names)}
        count = len(self.links)
        self.parent = np.full(count, -1)
        self.origin = np.broadcast_to(np.eye(4), (count, 4, 4)).copy()
        self.axis = np.zeros((count, 3))
        self.column = np.full(count, -1)  # joint position column, -1 for a fixed joint
        self.prismatic = np.zeros(count, dtype=bool)
        for i, link in enumerate(self.links[1:], start=1):
            joint = model.parent_joint(link)
            assert joint is not None  # every link below the root has one
            self.parent[i] = self.index[joint.parent]
            self.origin[i] = joint.origin
            if joint.movable and joint.name in column:
                self.column[i] = column[joint.name]
                self.axis[i] = joint.axis
                self.prismatic[i] = joint.type == "prismatic"
        self.moving = np.flatnonzero(self.column >= 0)
        # centre of mass: link masses and centres in the link frames
        self.mass = np.zeros(count)
        self.com_local = np.zeros((count, 3))
        for i, link in enumerate(self.links):
            inertial = model.links[link].inertial
            if inertial is not None:
                self.mass[i] = inertial.mass
                self.com_local[i] = inertial.origin[:3, 3]
        self.total_mass = float(self.mass.sum())

    def poses(self, base_position: Array, base_orientation: Array, q: Array) -> Array:
        """(links, 4, 4) world poses; base_orientation a quaternion (w, x, y, z)."""
        local = self.origin.copy()
        motion = np.broadcast_to(np.eye(4), (len(self.moving), 4, 4)).copy()
        angles = np.asarray(q, dtype=float)[self.column[self.moving]]
        axes = self.axis[self.moving]
        rotations = _rodrigues(axes, np.where(self.prismatic[self.moving], 0.0, angles))
        motion[:, :3, :3] = rotations
        motion[:, :3, 3] = axes * np.where(self.prismatic[self.moving], angles, 0.0)[:, None]
        local[self.moving] = local[self.moving] @ motion
        world = np.empty_like(local)
        world[0] = np.eye(4)
        world[0, :3, :3] = quat_to_matrix(np.asarray(base_orientation, dtype=float))
        world[0, :3, 3] = base_position
        for i in range(1, len(self.links)):
            world[i] = world[self.parent[i]] @ local[i]
        return world

    def com(self, poses: Array) -> Array:
        """Centre of mass [m] in the world frame of the poses."""
        centres = np.einsum("lij,lj->li", poses[:, :3, :3], self.com_local) + poses[:, :3, 3]
        return self.mass @ centres / self.total_mass


def _rodrigues(axes: Array, angles: Array) -> Array:
    """Rotation matrices (N, 3, 3) about unit axes (N, 3) by angles (N,)."""
    x, y, z = axes.T
    c, s = np.cos(angles), np.sin(angles)
    t = 1 - c
    return np.stack(
        [
            np.stack([t * x * x + c, t * x * y - s * z, t * x * z + s * y], -1),
            np.stack([t * x * y + s * z, t * y * y + c, t * y * z - s * x], -1),
            np.stack([t * x * z - s * y, t * y * z + s * x, t * z * z + c], -1),
        ],
        axis=-2,
    )


def quat_to_matrix(quat: Array) -> Array:
    """Rotation matrix of a unit quaternion (w, x, y, z) (normalised first)."""
    w, x, y, z = np.asarray(quat, dtype=float) / np.linalg.norm(quat)
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
            [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
            [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
        ]
    )


def matrices_to_quats(rotations: Array) -> Array:
    """Unit quaternions (N, 4) (w, x, y, z) of rotation matrices (N, 3, 3) (Shepperd's method,
    the largest of the four candidates for each matrix)."""
    r = np.asarray(rotations, dtype=float)
    trace = np.trace(r, axis1=1, axis2=2)
    diagonal = np.diagonal(r, axis1=1, axis2=2)
    candidates = np.stack(
        [
            np.stack([1 + trace, r[:, 2, 1] - r[:, 1, 2], r[:, 0, 2] - r[:, 2, 0],
                      r[:, 1, 0] - r[:, 0, 1]], -1),
            np.stack([r[:, 2, 1] - r[:, 1, 2], 1 + 2 * diagonal[:, 0] - trace,
                      r[:, 0, 1] + r[:, 1, 0], r[:, 0, 2] + r[:, 2, 0]], -1),
            np.stack([r[:, 0, 2] - r[:, 2, 0], r[:, 0, 1] + r[:, 1, 0],
                      1 + 2 * diagonal[:, 1] - trace, r[:, 1, 2] + r[:, 2, 1]], -1),
            np.stack([r[:, 1, 0] - r[:, 0, 1], r[:, 0, 2] + r[:, 2, 0],
                      r[:, 1, 2] + r[:, 2, 1], 1 + 2 * diagonal[:, 2] - trace], -1),
        ],
        axis=1,
    )  # fmt: skip
    # candidate k has component k equal to 4 q_k^2 >= 0: pick the largest for accuracy
    pick = np.argmax(np.stack([1 + trace, *(1 + 2 * diagonal.T - trace)], -1), axis=1)
    quats = candidates[np.arange(len(r)), pick]
    quats /= np.linalg.norm(quats, axis=1, keepdims=True)
    return np.where(quats[:, :1] < 0, -quats, quats)
