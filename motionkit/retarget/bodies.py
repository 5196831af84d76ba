"""The robot's limbs, feet and jets as capsules: for the clearance metric and, in the IK's URDF,
for PlaCo's self-collision avoidance.

The IK's URDF writes each capsule as a collision cylinder of the capsule's segment length and
lists it under the link's <collision_checking> (an extension that pinocchio reads): pinocchio
then loads a capsule. The closest points of two capsules move smoothly with the pose; those of
a flat cylinder end jump from edge to edge, and the IK's iterations could then cycle between
two poses instead of settling.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from dataclasses import dataclass

import numpy as np

from motionkit.retarget.points import Point
from motionkit.retarget.targets import SIDES
from motionkit.robot import Robot
from motionkit.robot.geometry import Array
from motionkit.robot.urdf import RobotModel, Shape


@dataclass(frozen=True)
class Capsule:
    name: str
    start: Point
    end: Point
    radius: float  # m


def capsules(robot: Robot, points: dict[str, Point]) -> tuple[list[Capsule], set[frozenset]]:
    """Limb and foot capsules (radii are rough sizes of a humanoid's links), the capsules of the
    jets the spec gives a size, and the pairs that share a joint or a mounting (they may touch
    by design)."""
    shapes, adjacent = [], set()
    poses = robot.model.link_poses()
    hands = dict(zip(robot.spec.hands, SIDES, strict=False))
    for k, side in enumerate(SIDES):
        foot = robot.spec.feet[k]
        sole = np.linalg.inv(poses[foot.sole])
        local = np.array([(sole @ poses[c])[:3, 3] for c in foot.corners])
        shapes += [
            Capsule(f"{side}_thigh", points[f"{side}_hip"], points[f"{side}_knee"], 0.06),
            Capsule(f"{side}_shank", points[f"{side}_knee"], points[f"{side}_ankle"], 0.05),
            Capsule(
                f"{side}_foot",
                Point(foot.sole, local[:2].mean(axis=0)),
                Point(foot.sole, local[2:].mean(axis=0)),
                0.03,
            ),
            Capsule(f"{side}_upper_arm", points[f"{side}_shoulder"], points[f"{side}_elbow"], 0.04),
        ]
        adjacent |= {
            frozenset((f"{side}_thigh", f"{side}_shank")),
            frozenset((f"{side}_shank", f"{side}_foot")),
        }
    for jet in (jet for jet in robot.spec.jets if jet.length > 0):
        top = Point(jet.frame, np.array([0.0, 0.0, -jet.length]))
        shapes.append(Capsule(f"jet_{jet.name}", Point(jet.frame, np.zeros(3)), top, jet.radius))
        if jet.frame in hands:
            adjacent.add(frozenset((f"jet_{jet.name}", f"{hands[jet.frame]}_upper_arm")))
    return shapes, adjacent


def segment_distance(p0: Array, p1: Array, q0: Array, q1: Array) -> Array:
    """Distance between segments p0-p1 and q0-q1, vectorised over the leading axis."""
    u, v, w = p1 - p0, q1 - q0, p0 - q0
    a, b, c = (u * u).sum(-1), (u * v).sum(-1), (v * v).sum(-1)
    d, e = (u * w).sum(-1), (v * w).sum(-1)
    denominator = np.maximum(a * c - b * b, 1e-12)
    s = np.clip((b * e - c * d) / denominator, 0.0, 1.0)
    t = np.clip((b * s + e) / np.maximum(c, 1e-12), 0.0, 1.0)
    s = np.clip((b * t - d) / np.maximum(a, 1e-12), 0.0, 1.0)
    return np.linalg.norm(w + s[:, None] * u - t[:, None] * v, axis=-1)


def avoided(a: Capsule, b: Capsule) -> bool:
    """Whether the IK keeps this pair apart: those with a jet or an upper arm in them."""
    return any(n.startswith("jet_") or n.endswith("_upper_arm") for n in (a.name, b.name))


def host_link(model: RobotModel, capsule: Capsule) -> str:
    """The link that carries the capsule: where both ends are fixed. A limb capsule runs from a
    joint centre to the origin of the next link, which is fixed in that link's parent."""
    if capsule.start.link == capsule.end.link:
        return capsule.end.link
    for joint in model.joints.values():
        if joint.child == capsule.end.link:
            return joint.parent
    raise ValueError(f"capsule {capsule.name}: no joint moves link '{capsule.end.link}'")


def with_collision_cylinders(model: RobotModel, shapes: list[Capsule]) -> RobotModel:
    """A copy of `model` whose only collision elements are the capsules' segments, as cylinders
    of the segment's length and the capsule's radius in their host links (see `capsule_urdf`).
    Visuals are dropped."""
    out = model.copy()
    poses = model.link_poses()
    for link in out.links.values():
        link.visuals, link.collisions = [], []
    for capsule in shapes:
        host = host_link(model, capsule)
        to_host = np.linalg.inv(poses[host])
        ends = [
            (to_host @ poses[p.link] @ np.append(p.offset, 1.0))[:3]
            for p in (capsule.start, capsule.end)
        ]
        axis = ends[1] - ends[0]
        length = float(np.linalg.norm(axis))
        origin = np.eye(4)
        origin[:3, :3] = _z_to(axis / length)
        origin[:3, 3] = 0.5 * (ends[0] + ends[1])
        geometry = ET.Element("geometry")
        ET.SubElement(geometry, "cylinder", radius=repr(capsule.radius), length=repr(length))
        out.links[host].collisions.append(Shape(origin, geometry))
    return out


def capsule_urdf(model: RobotModel, shapes: list[Capsule], header: str = "") -> str:
    """The URDF text of `with_collision_cylinders(model, shapes)` with every collision cylinder
    named ('<link>_capsule_<n>') and listed as a capsule in its link's <collision_checking>:
    pinocchio loads each as a capsule of the cylinder's radius and length (its segment)."""
    text = with_collision_cylinders(model, shapes).to_urdf(header)
    head, _, body = text.partition("<robot")
    robot = ET.fromstring("<robot" + body)
    for link in robot.iter("link"):
        cylinders = link.findall("collision")
        if not cylinders:
            continue
        checking = ET.SubElement(link, "collision_checking")
        for n, collision in enumerate(cylinders):
            name = f"{link.get('name')}_capsule_{n}"
            collision.set("name", name)
            ET.SubElement(checking, "capsule", name=name)
    ET.indent(robot, space="  ")
    return f"{head}{ET.tostring(robot, encoding='unicode')}\n"


def _z_to(direction: Array) -> Array:
    """A rotation whose z axis is `direction` (unit)."""
    helper = np.array([1.0, 0.0, 0.0]) if abs(direction[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    x = np.cross(helper, direction)
    x /= np.linalg.norm(x)
    return np.stack([x, np.cross(direction, x), direction], axis=1)
