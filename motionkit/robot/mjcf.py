"""MJCF export for MuJoCo and MJX: a free base, one body per moving link, a site per link frame,
box soles for contact, PD position actuators for the spec's joints and one thrust actuator per jet.

MuJoCo's generalised coordinates follow the spec's joint order (children are written in the
order of the first spec joint below them), so qpos[7:] lines up with `Robot.joint_names`.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from typing import TYPE_CHECKING

import numpy as np

from motionkit import __version__
from motionkit.core.errors import RobotModelError
from motionkit.robot.geometry import Array, matrix_to_quat
from motionkit.robot.spec import THRUST_AXIS, FootSpec
from motionkit.robot.urdf import Inertial, Joint, RobotModel

if TYPE_CHECKING:
    from motionkit.robot.model import Robot

SOLE_THICKNESS = 0.01  # m, height of the sole collision boxes (bottom face on the corners)
FREE_JOINT = "root"


def _fmt(values: Array | list[float] | tuple[float, ...]) -> str:
    return " ".join("0" if abs(v) < 1e-15 else repr(float(v)) for v in np.ravel(values))


def _pose_attrs(transform: Array) -> dict[str, str]:
    attrs = {"pos": _fmt(transform[:3, 3])}
    if not np.allclose(transform[:3, :3], np.eye(3), atol=1e-15):
        attrs["quat"] = _fmt(matrix_to_quat(transform[:3, :3]))
    return attrs


class _Writer:
    def __init__(self, robot: Robot) -> None:
        self.robot = robot
        self.model: RobotModel = robot.model
        self.order = {name: i for i, name in enumerate(robot.joint_names)}
        self.frame_in_body: dict[str, tuple[str, Array]] = {}
        self.bodies: dict[str, ET.Element] = {}

    def first_spec_joint(self, link: str) -> int:
        below = [
            self.order.get(j.name, len(self.order))
            for name in self.model.subtree(link)
            if (j := self.model.parent_joint(name)) is not None
        ]
        return min(below, default=len(self.order))

    def link(self, name: str, body: ET.Element, offset: Array) -> None:
        """Write link `name` into `body`, whose frame is `offset` away from the link frame."""
        link = self.model.links[name]
        if link.inertial is not None:
            self.inertial(body, offset, link.inertial)
        ET.SubElement(body, "site", name=name, **_pose_attrs(offset))
        self.frame_in_body[name] = (body.get("name", ""), offset)
        children = sorted(
            self.model.child_joints(name), key=lambda j: self.first_spec_joint(j.child)
        )
        for joint in children:
            self.child(joint, body, offset)

    def child(self, joint: Joint, body: ET.Element, offset: Array) -> None:
        child_offset = offset @ joint.origin
        if joint.type == "fixed" and self.model.links[joint.child].inertial is None:
            self.link(joint.child, body, child_offset)  # a massless frame: a site in this body
            return
        child = ET.SubElement(body, "body", name=joint.child, **_pose_attrs(child_offset))
        if joint.type != "fixed":
            attrs = {"name": joint.name, "axis": _fmt(joint.axis)}
            attrs["type"] = "slide" if joint.type == "prismatic" else "hinge"
            if joint.type != "continuous":
                attrs["range"] = _fmt([joint.lower, joint.upper])
            ET.SubElement(child, "joint", **attrs)
        self.bodies[joint.child] = child
        self.link(joint.child, child, np.eye(4))

    @staticmethod
    def inertial(body: ET.Element, offset: Array, inertial: Inertial) -> None:
        frame = offset @ inertial.origin
        rotation = frame[:3, :3]
        full = rotation @ inertial.inertia @ rotation.T
        ET.SubElement(
            body,
            "inertial",
            pos=_fmt(frame[:3, 3]),
            mass=repr(float(inertial.mass)),
            fullinertia=_fmt(
                [full[0, 0], full[1, 1], full[2, 2], full[0, 1], full[0, 2], full[1, 2]]
            ),
        )

    def sole_box(self, foot: FootSpec) -> None:
        body_name, sole = self.frame_in_body[foot.sole]
        corners = []
        for corner in foot.corners:
            corner_body, pose = self.frame_in_body[corner]
            if corner_body != body_name:
                raise RobotModelError(
                    f"{self.model.source}: sole corner '{corner}' and sole '{foot.sole}' are on "
                    "different rigid bodies"
                )
            corners.append(pose[:3, 3])
        local = (np.array(corners) - sole[:3, 3]) @ sole[:3, :3]  # corners in the sole frame
        low, high = local.min(axis=0), local.max(axis=0)
        if high[2] - low[2] > 1e-3:
            raise RobotModelError(
                f"{self.model.source}: the corners of '{foot.sole}' are not in a plane parallel "
                "to the sole (z spread {:.4f} m)".format(high[2] - low[2])
            )
        half = np.array([(high[0] - low[0]) / 2, (high[1] - low[1]) / 2, SOLE_THICKNESS / 2])
        center = (
            sole[:3, :3] @ np.array([*(low[:2] + high[:2]) / 2, low[2] + half[2]]) + sole[:3, 3]
        )
        box = np.eye(4)
        box[:3, :3], box[:3, 3] = sole[:3, :3], center
        body = self.bodies[body_name]
        ET.SubElement(
            body,
            "geom",
            name=f"{foot.side}_sole",
            type="box",
            size=_fmt(half),
            friction=_fmt([self.robot.spec.simulation.friction, 0.02, 0.002]),
            rgba="0.3 0.3 0.35 1",
            **_pose_attrs(box),
        )


def to_mjcf(robot: Robot) -> str:
    """The MJCF text of the robot on a floor; keyframe 'stand' is the spec's standing posture."""
    spec, model, sim = robot.spec, robot.model, robot.spec.simulation
    writer = _Writer(robot)
    root = ET.Element("mujoco", model=robot.name)
    ET.SubElement(root, "compiler", angle="radian", autolimits="true")
    ET.SubElement(root, "option", timestep=repr(sim.timestep), integrator="implicitfast")
    default = ET.SubElement(root, "default")
    ET.SubElement(default, "joint", armature=repr(sim.armature), damping=repr(sim.damping))
    ET.SubElement(default, "geom", contype="1", conaffinity="1", condim="3")
    ET.SubElement(default, "site", size="0.005", group="4")
    world = ET.SubElement(root, "worldbody")
    ET.SubElement(world, "light", pos="0 0 4", dir="0 0 -1", directional="true")
    ET.SubElement(world, "geom", name="floor", type="plane", size="0 0 0.05", rgba="0.8 0.8 0.8 1")
    base = ET.SubElement(world, "body", name=spec.root, pos="0 0 1")
    ET.SubElement(base, "freejoint", name=FREE_JOINT)
    writer.bodies[spec.root] = base
    writer.link(spec.root, base, np.eye(4))
    for foot in spec.feet:
        writer.sole_box(foot)

    actuators = ET.SubElement(root, "actuator")
    for name in robot.joint_names:
        joint = model.joints[name]
        kp, kd = sim.gains(name)
        attrs = {"name": name, "joint": name, "kp": repr(kp), "kv": repr(kd)}
        if joint.type != "continuous":
            attrs["ctrlrange"] = _fmt([joint.lower, joint.upper])
        attrs["forcerange"] = _fmt([-joint.effort, joint.effort])
        ET.SubElement(actuators, "position", **attrs)
    for jet in spec.jets:
        ET.SubElement(
            actuators,
            "motor",
            name=f"jet_{jet.name}",
            site=jet.frame,
            gear=_fmt([*THRUST_AXIS, 0, 0, 0]),
            ctrlrange=_fmt([0, jet.t_max]),
            forcerange=_fmt([0, jet.t_max]),
        )

    keyframe = ET.SubElement(root, "keyframe")
    posture = spec.posture_angles()
    angles = [posture[name] for name in robot.joint_names]
    height = standing_height(robot, posture)
    ET.SubElement(
        keyframe,
        "key",
        name="stand",
        qpos=_fmt([0, 0, height, 1, 0, 0, 0, *angles]),
        ctrl=_fmt(angles + [0.0] * len(spec.jets)),
    )
    ET.indent(root, space="  ")
    header = f"<!-- {robot.name}: generated by motionkit {__version__} from {robot.origin} -->\n"
    return header + ET.tostring(root, encoding="unicode") + "\n"


def standing_height(robot: Robot, posture: dict[str, float]) -> float:
    """Base height that puts the lowest sole corner on the floor in the standing posture."""
    poses = robot.model.link_poses(posture)
    corners = [poses[c][2, 3] for foot in robot.spec.feet for c in foot.corners]
    return -min(corners) if corners else 1.0
