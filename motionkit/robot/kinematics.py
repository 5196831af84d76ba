"""Forward kinematics over many frames at once (numpy): joint transforms and frame poses.

`RobotModel.link_poses` computes one configuration; these functions take a (T, J) array of joint
positions and return (T, ..., 4, 4) transforms, for datasets, AMP features and `/tf`.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from scipy.spatial.transform import Rotation

from motionkit.core.errors import RobotModelError
from motionkit.robot.geometry import Array
from motionkit.robot.urdf import Joint, RobotModel


def joint_transforms(joint: Joint, q: Array | None, frames: int) -> Array:
    """Child-in-parent transforms (frames, 4, 4) of a joint at positions q (frames,); a fixed
    joint, or q None, gives its origin at every frame."""
    if q is None or not joint.movable:
        return np.broadcast_to(joint.origin, (frames, 4, 4))
    motion = np.broadcast_to(np.eye(4), (frames, 4, 4)).copy()
    if joint.type == "prismatic":
        motion[:, :3, 3] = q[:, None] * joint.axis
    else:
        motion[:, :3, :3] = Rotation.from_rotvec(q[:, None] * joint.axis).as_matrix()
    return joint.origin @ motion


def frame_poses(
    model: RobotModel, joint_names: Sequence[str], joint_positions: Array, frames: Sequence[str]
) -> Array:
    """Poses (T, len(frames), 4, 4) of the named links relative to the root link, at joint
    positions (T, J) given in `joint_names` order; joints not named stay at zero."""
    positions = np.asarray(joint_positions, dtype=float)
    count = positions.shape[0]
    column = {name: i for i, name in enumerate(joint_names)}
    model.require_frames(list(frames), "forward kinematics")
    poses: dict[str, Array] = {model.root: np.broadcast_to(np.eye(4), (count, 4, 4))}

    def pose(link: str) -> Array:
        chain, top = [], link  # the joints up from `link` to a link already posed
        while top not in poses:
            joint = model.parent_joint(top)
            if joint is None:
                raise RobotModelError(f"{model.source}: link '{top}' has no parent joint")
            chain.append(joint)
            top = joint.parent
        for joint in reversed(chain):
            q = positions[:, column[joint.name]] if joint.name in column else None
            poses[joint.child] = poses[joint.parent] @ joint_transforms(joint, q, count)
        return poses[link]

    return np.stack([pose(frame) for frame in frames], axis=1)
