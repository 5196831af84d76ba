"""The robot in a viser scene: meshes on link frames, and the overlays that follow a frame.

Overlays: thrust arrows out of the nozzles (along the exhaust, opposite to the force on the robot,
length THRUST_LENGTH x T/T_max), sole corners green in contact and grey off it, the centre of
mass with its ground projection, and the planned contact forces when a clip has them (an arrow
per sole corner from the corner, FORCE_SCALE m per body weight, none below FORCE_THRESHOLD).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import viser

from motionkit.robot import THRUST_AXIS, Robot
from motionkit.robot.geometry import Array
from motionkit.viewer.meshes import LinkMesh
from motionkit.viewer.posing import LinkPoser, matrices_to_quats

THRUST_LENGTH = 0.6  # m, arrow length at T_max
FORCE_SCALE = 0.5  # m per body weight of contact force
FORCE_THRESHOLD = 1e-3  # body weights: smaller forces draw no arrow
CONTACT_COLOR = np.array([40, 200, 80], np.uint8)
FREE_COLOR = np.array([150, 150, 150], np.uint8)
THRUST_COLOR = (255, 120, 20)
FORCE_COLOR = (220, 40, 200)
COM_COLOR = (230, 30, 30)


@dataclass(frozen=True)
class FrameState:
    """What one frame of a clip shows."""

    base_position: Array  # (3,)
    base_orientation: Array  # (4,) w, x, y, z
    joint_positions: Array  # (J,)
    thrust: Array | None = None  # (jets,) [N]
    contacts: Array | None = None  # (feet,) bool
    contact_forces: Array | None = None  # (corners, 3) [N], world frame


class RobotScene:
    """The robot's meshes under `prefix`, and the overlays; `show(state)` poses everything."""

    def __init__(
        self,
        server: viser.ViserServer,
        robot: Robot,
        meshes: list[LinkMesh],
        prefix: str = "/robot",
    ) -> None:
        self.server, self.robot, self.prefix = server, robot, prefix
        self.poser = LinkPoser(robot)
        self.root = server.scene.add_frame(prefix, show_axes=False)
        shown = sorted({mesh.link for mesh in meshes}, key=self.poser.index.__getitem__)
        self.mesh_links = np.array([self.poser.index[link] for link in shown], dtype=int)
        self.frames = {
            link: server.scene.add_frame(f"{prefix}/{link}", show_axes=False) for link in shown
        }
        for k, mesh in enumerate(meshes):
            server.scene.add_mesh_simple(
                f"{prefix}/{mesh.link}/visual_{k}", mesh.vertices, mesh.faces, color=mesh.color
            )
        spec = robot.spec
        self.jets = np.array([self.poser.index[jet.frame] for jet in spec.jets], dtype=int)
        self.t_max = np.array([jet.t_max for jet in spec.jets])
        corners = [corner for foot in spec.feet for corner in foot.corners]
        self.corners = np.array([self.poser.index[c] for c in corners], dtype=int)
        self.corner_foot = np.repeat(
            np.arange(len(spec.feet)), [len(foot.corners) for foot in spec.feet]
        )
        self.thrust = server.scene.add_arrows(
            "/overlays/thrust", np.zeros((1, 2, 3), np.float32), THRUST_COLOR, visible=False
        )
        self.contacts = server.scene.add_point_cloud(
            "/overlays/contacts",
            np.zeros((len(corners), 3), np.float32),
            np.tile(FREE_COLOR, (len(corners), 1)),
            point_size=0.03,
            point_shape="circle",
            precision="float32",
        )
        self.com = server.scene.add_icosphere("/overlays/com", 0.03, COM_COLOR, subdivisions=2)
        self.com_line = server.scene.add_line_segments(
            "/overlays/com_ground", np.zeros((1, 2, 3), np.float32), COM_COLOR, thickness=0.005
        )
        self.forces = server.scene.add_arrows(
            "/overlays/contact_forces", np.zeros((1, 2, 3), np.float32), FORCE_COLOR, visible=False
        )
        self.show_forces = True  # draw contact forces when the frame has them
        self.poses: Array = np.empty((0, 4, 4))
        self.state: FrameState | None = None

    def set_visible(self, visible: bool) -> None:
        self.root.visible = visible
        for handle in (self.contacts, self.com, self.com_line):
            handle.visible = visible
        if not visible:
            self.thrust.visible = self.forces.visible = False

    def show(self, state: FrameState) -> Array:
        """Pose the robot and overlays for one frame (one atomic update); the link poses."""
        poses = self.poser.poses(state.base_position, state.base_orientation, state.joint_positions)
        shown = poses[self.mesh_links]
        quats = matrices_to_quats(shown[:, :3, :3])
        with self.server.atomic():
            for handle, quat, pose in zip(self.frames.values(), quats, shown, strict=True):
                handle.wxyz = quat
                handle.position = pose[:3, 3]
            self._overlays(state, poses)
        self.poses, self.state = poses, state
        return poses

    def _overlays(self, state: FrameState, poses: Array) -> None:
        corners = poses[self.corners, :3, 3]
        self.contacts.points = corners.astype(np.float32)
        if state.contacts is not None and len(state.contacts):
            touching = np.asarray(state.contacts, bool)[self.corner_foot]
            self.contacts.colors = np.where(touching[:, None], CONTACT_COLOR, FREE_COLOR)
        com = self.poser.com(poses)
        self.com.position = com
        self.com_line.points = np.array([[com, [com[0], com[1], 0.0]]], np.float32)
        self.thrust.visible = self._thrust_arrows(state, poses) if self.root.visible else False
        drawn = self.root.visible and self.show_forces
        self.forces.visible = self._force_arrows(state, corners) if drawn else False

    def _thrust_arrows(self, state: FrameState, poses: Array) -> bool:
        if state.thrust is None or not len(state.thrust):
            return False
        share = np.clip(np.asarray(state.thrust, float) / self.t_max, 0.0, None)
        on = share > 0.01
        if not on.any():
            return False
        jets = poses[self.jets[on]]
        exhaust = -jets[:, :3, :3] @ np.asarray(THRUST_AXIS)  # opposite to the force
        start = jets[:, :3, 3]
        end = start + exhaust * (THRUST_LENGTH * share[on])[:, None]
        self.thrust.points = np.stack([start, end], axis=1).astype(np.float32)
        return True

    def _force_arrows(self, state: FrameState, corners: Array) -> bool:
        if state.contact_forces is None:
            return False
        forces = np.asarray(state.contact_forces, float)
        weight = self.poser.total_mass * 9.81
        on = np.linalg.norm(forces, axis=1) > FORCE_THRESHOLD * weight
        if not on.any():
            return False
        end = corners[on] + forces[on] * (FORCE_SCALE / weight)
        self.forces.points = np.stack([corners[on], end], axis=1).astype(np.float32)
        return True

    def link_pose(self, link: str) -> Array:
        """World pose (4, 4) of a link at the frame shown last."""
        return self.poses[self.poser.index[link]]
