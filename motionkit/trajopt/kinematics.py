"""The robot's kinematics as small CasADi functions (adam-robotics, mixed velocity representation).

The configuration is q = (base position [m], base quaternion (w, x, y, z), joint angles in spec
order) and the velocity nu = (base linear and angular velocity in the world frame, joint
velocities). One SX function `knot(q, nu)` gives everything a knot of the problem needs: the
CoM, the centroidal momentum (linear, then angular about the CoM, world axes), the sole-corner
positions and the jet nozzle positions and thrust directions (-z of each jet frame).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import casadi as cs
import numpy as np

from motionkit.core.errors import TrajoptError
from motionkit.core.extras import require
from motionkit.robot import Robot
from motionkit.robot.model import cached_file
from motionkit.robot.spec import THRUST_AXIS

GRAVITY = 9.80665  # m/s^2, adam's default gravity


def quat_to_matrix(quat: cs.SX) -> cs.SX:
    """Rotation matrix of a quaternion (w, x, y, z); the quaternion is normalised first."""
    w, x, y, z = cs.vertsplit(quat / cs.norm_2(quat))
    return cs.vertcat(
        cs.horzcat(1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)),
        cs.horzcat(2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)),
        cs.horzcat(2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)),
    )


def base_transform(q: cs.SX) -> cs.SX:
    transform = cs.SX.eye(4)
    transform[:3, :3] = quat_to_matrix(q[3:7])
    transform[:3, 3] = q[:3]
    return transform


def kinematic_urdf_path(robot: Robot) -> str:
    """The robot's URDF without meshes (adam parses it quickly), cached by model hash."""
    model = robot.model.copy()
    for link in model.links.values():
        link.visuals, link.collisions = [], []
    text = model.to_urdf(f"{robot.name} without meshes, for trajopt")
    return str(cached_file(robot, "trajopt_kinematics.urdf", text))


@dataclass(frozen=True)
class Layout:
    joints: int
    corners: int
    jets: int

    @property
    def nq(self) -> int:
        return 7 + self.joints

    @property
    def nv(self) -> int:
        return 6 + self.joints


class RobotKinematics:
    """CasADi kinematics of one robot; built once per process (a few seconds)."""

    def __init__(self, robot: Robot) -> None:
        require("trajopt", "trajectory optimisation", TrajoptError)
        from adam.casadi import KinDynComputations

        self.robot = robot
        self.corner_frames = tuple(c for foot in robot.spec.feet for c in foot.corners)
        self.jet_frames = tuple(jet.frame for jet in robot.spec.jets)
        self.layout = Layout(len(robot.joint_names), len(self.corner_frames), len(self.jet_frames))
        options = {"cse": True}
        self._kd = KinDynComputations(
            kinematic_urdf_path(robot), list(robot.joint_names), f_opts=options
        )
        self.mass = float(self._kd.get_total_mass())

    @cached_property
    def knot(self) -> cs.Function:
        """knot(q, nu) -> (com 3, momentum 6, corners 3 x C, jet positions 3 x J, jet thrust
        directions 3 x J): one SX function, so that CasADi differentiates it as one graph."""
        lay = self.layout
        q, nu = cs.SX.sym("q", lay.nq), cs.SX.sym("nu", lay.nv)
        transform, joints = base_transform(q), q[7:]
        kd = self._kd
        com = kd.CoM_position(transform, joints)
        momentum = cs.mtimes(kd.centroidal_momentum_matrix(transform, joints), nu)
        corners = [kd.forward_kinematics(f, transform, joints)[:3, 3] for f in self.corner_frames]
        jet_poses = [kd.forward_kinematics(f, transform, joints) for f in self.jet_frames]
        axis = cs.DM(THRUST_AXIS)
        return cs.Function(
            "knot",
            [q, nu],
            [
                com,
                momentum,
                cs.horzcat(*corners),
                cs.horzcat(*(pose[:3, 3] for pose in jet_poses)),
                cs.horzcat(*(cs.mtimes(pose[:3, :3], axis) for pose in jet_poses)),
            ],
            ["q", "nu"],
            ["com", "momentum", "corners", "jet_pos", "jet_dir"],
            {"cse": True},
        )

    def evaluate(self, q: np.ndarray, nu: np.ndarray | None = None) -> dict[str, np.ndarray]:
        """The knot quantities at one configuration, as numpy arrays."""
        nu = np.zeros(self.layout.nv) if nu is None else nu
        out = self.knot(q=q, nu=nu)
        return {name: np.array(value) for name, value in out.items()}
