"""The human skeleton of a retargeted clip, drawn beside the robot.

The clip's landmarks (the low-passed human scaled to the robot: what it was retargeted to) are
moved sideways by a fixed offset: `offset` metres along the robot's left, horizontal, at the
clip's first frame, so that the skeleton stands beside the robot and moves exactly as recorded.
Bones (parent -> child) are one line-segments object and the landmarks one batched sphere mesh:
a frame is two vectorised array updates, however many landmarks.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np

from motionkit.robot.geometry import Array
from motionkit.viewer.posing import quat_to_matrix

if TYPE_CHECKING:
    import viser

SKELETON_OFFSET = 1.0  # m, to the robot's left by default
BONE_COLOR = (40, 110, 230)
JOINT_COLOR = (20, 60, 160)
BONE_THICKNESS = 0.012  # m
JOINT_RADIUS = 0.025  # m


def side_offset(forward: Sequence[float], base_orientation: Array, metres: float) -> Array:
    """(3,) world offset [m]: `metres` along the robot's left (up x forward in its root frame)
    at `base_orientation` (w, x, y, z), made horizontal; world +y when the left is vertical."""
    left_root = np.cross([0.0, 0.0, 1.0], np.asarray(forward, dtype=float))
    left = quat_to_matrix(np.asarray(base_orientation, dtype=float)) @ left_root
    left[2] = 0.0
    norm = np.linalg.norm(left)
    direction = left / norm if norm > 1e-6 else np.array([0.0, 1.0, 0.0])
    return metres * direction


def bone_indices(parents: Sequence[int]) -> tuple[np.ndarray, np.ndarray]:
    """(parent, child) landmark indices of every bone (every landmark that has a parent)."""
    parents = np.asarray(parents, dtype=int)
    children = np.flatnonzero(parents >= 0)
    return parents[children], children


class SkeletonOverlay:
    """One clip's skeleton in a viser scene under `name`; `show(landmarks)` poses one frame."""

    def __init__(
        self,
        server: viser.ViserServer,
        parents: Sequence[int],
        offset: Array,
        visible: bool = True,
        name: str = "/overlays/skeleton",
    ) -> None:
        import trimesh

        self.offset = np.asarray(offset, dtype=float)
        self.parent, self.child = bone_indices(parents)
        count = len(parents)
        self.bones = server.scene.add_line_segments(
            f"{name}/bones",
            np.zeros((max(len(self.child), 1), 2, 3), np.float32),
            BONE_COLOR,
            thickness=BONE_THICKNESS,
            visible=visible and len(self.child) > 0,
        )
        sphere = trimesh.creation.icosphere(subdivisions=1, radius=JOINT_RADIUS)
        self.joints = server.scene.add_batched_meshes_simple(
            f"{name}/joints",
            np.asarray(sphere.vertices, np.float32),
            np.asarray(sphere.faces, np.uint32),
            batched_wxyzs=np.tile(np.array([1.0, 0.0, 0.0, 0.0], np.float32), (count, 1)),
            batched_positions=np.zeros((count, 3), np.float32),
            batched_colors=JOINT_COLOR,
            cast_shadow=False,
            visible=visible,
        )
        self._visible = visible

    @property
    def visible(self) -> bool:
        return self._visible

    @visible.setter
    def visible(self, visible: bool) -> None:
        self._visible = visible
        self.bones.visible = visible and len(self.child) > 0
        self.joints.visible = visible

    def show(self, landmarks: Array) -> None:
        """Pose the skeleton at one frame's landmarks (L, 3) [m], plus the offset."""
        points = (np.asarray(landmarks, dtype=float) + self.offset).astype(np.float32)
        if len(self.child):
            self.bones.points = np.stack([points[self.parent], points[self.child]], axis=1)
        self.joints.batched_positions = points

    def remove(self) -> None:
        self.bones.remove()
        self.joints.remove()
