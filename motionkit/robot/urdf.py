"""A small URDF tree: parse, edit, check and write the subset of URDF motionkit uses.

Links carry inertials and visual/collision shapes; joints carry origins, axes and limits.
Everything is a float array in SI units; origins are 4x4 homogeneous transforms.
"""

from __future__ import annotations

import copy
import difflib
import xml.etree.ElementTree as ET
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from motionkit.core.errors import RobotModelError
from motionkit.files.inputs import read_text
from motionkit.robot.geometry import Array, axis_angle, make_transform, matrix_to_rpy

MOVABLE = ("revolute", "continuous", "prismatic")
JOINT_TYPES = (*MOVABLE, "fixed")  # URDF's floating and planar joints are not supported
# A principal moment below this is treated as zero when checking inertias [kg m^2].
INERTIA_TOLERANCE = 1e-12


@dataclass
class Inertial:
    mass: float
    origin: Array  # centre of mass frame in the link frame
    inertia: Array  # 3x3 about the centre of mass, in the origin frame


@dataclass
class Shape:
    """A visual or collision element: its origin and a copy of its <geometry> XML."""

    origin: Array
    geometry: ET.Element
    rgba: tuple[float, float, float, float] | None = None


@dataclass
class Link:
    name: str
    inertial: Inertial | None = None
    visuals: list[Shape] = field(default_factory=list)
    collisions: list[Shape] = field(default_factory=list)


@dataclass
class Joint:
    name: str
    type: str
    parent: str
    child: str
    origin: Array
    axis: Array = field(default_factory=lambda: np.array([1.0, 0.0, 0.0]))
    lower: float = 0.0
    upper: float = 0.0
    velocity: float = 0.0
    effort: float = 0.0

    @property
    def movable(self) -> bool:
        return self.type in MOVABLE

    def motion(self, q: float) -> Array:
        """Transform of the child frame relative to the joint frame at position q."""
        if self.type in ("revolute", "continuous"):
            return axis_angle(self.axis, q)
        if self.type == "prismatic":
            return make_transform(xyz=self.axis * q)
        return np.eye(4)


@dataclass
class RobotModel:
    name: str
    links: dict[str, Link]
    joints: dict[str, Joint]
    source: str = "<memory>"

    # -- structure ---------------------------------------------------------------------
    @property
    def root(self) -> str:
        children = {j.child for j in self.joints.values()}
        roots = [name for name in self.links if name not in children]
        if not self.links:
            raise RobotModelError(f"{self.source}: the robot has no links")
        if not roots:
            raise RobotModelError(
                f"{self.source}: no root link: {_cycle(self, next(iter(self.links)))}"
            )
        if len(roots) > 1:
            raise RobotModelError(
                f"{self.source}: {len(roots)} root links (no joint leads to them): "
                f"{', '.join(roots)}; expected one root link: the links must form one tree"
            )
        return roots[0]

    def child_joints(self, link: str) -> list[Joint]:
        return [j for j in self.joints.values() if j.parent == link]

    def parent_joint(self, link: str) -> Joint | None:
        return next((j for j in self.joints.values() if j.child == link), None)

    def subtree(self, link: str) -> list[str]:
        """The link and every link below it, depth first."""
        children: dict[str, list[str]] = {}
        for joint in self.joints.values():
            children.setdefault(joint.parent, []).append(joint.child)
        names, stack = [], [link]
        while stack:
            names.append(stack.pop())
            stack += reversed(children.get(names[-1], []))
        return names

    def remove_subtree(self, link: str) -> None:
        doomed = set(self.subtree(link))
        for name in doomed:
            del self.links[name]
        self.joints = {n: j for n, j in self.joints.items() if j.child not in doomed}

    def movable_joints(self) -> list[Joint]:
        return [j for j in self.joints.values() if j.movable]

    def total_mass(self) -> float:
        return sum(link.inertial.mass for link in self.links.values() if link.inertial)

    def require_frames(self, frames: Sequence[str], what: str) -> None:
        if isinstance(frames, str):
            raise RobotModelError(f"{what}: expected a list of link names, got {frames!r}")
        missing = [f for f in frames if f not in self.links]
        if missing:
            close = {m: difflib.get_close_matches(m, self.links, 1) for m in missing}
            hints = [f"{m} (did you mean {c[0]}?)" if c else m for m, c in close.items()]
            raise RobotModelError(
                f"{self.source}: no link named {', '.join(hints)} (needed for {what})"
            )

    # -- kinematics (plain numpy; used for building, not in hot loops) ---------------------
    def link_poses(self, q: dict[str, float] | None = None) -> dict[str, Array]:
        """World transform of every link with the root at the origin; joints absent from q at 0."""
        q = q or {}
        poses = {self.root: np.eye(4)}
        stack = [self.root]
        while stack:
            link = stack.pop()
            for joint in self.child_joints(link):
                poses[joint.child] = (
                    poses[link] @ joint.origin @ joint.motion(q.get(joint.name, 0.0))
                )
                stack.append(joint.child)
        return poses

    # -- checks ------------------------------------------------------------------------
    def check_inertias(self) -> None:
        """Every mass positive and every inertia physically valid (positive principal moments
        that satisfy the triangle inequality), or a RobotModelError naming the link."""
        for link in self.links.values():
            if link.inertial is None:
                continue
            mass, inertia = link.inertial.mass, link.inertial.inertia
            problem = inertia_problem(mass, inertia)
            if problem:
                raise RobotModelError(
                    f"{self.source}: link '{link.name}' has an invalid inertia ({problem})"
                )

    # -- output ------------------------------------------------------------------------
    def to_urdf(self, header: str = "") -> str:
        """Deterministic URDF text: links then joints, both depth first from the root."""
        robot = ET.Element("robot", name=self.name)
        order = self.subtree(self.root)
        for name in order:
            robot.append(_link_xml(self.links[name]))
        for name in order[1:]:
            joint = self.parent_joint(name)
            assert joint is not None
            robot.append(_joint_xml(joint))
        ET.indent(robot, space="  ")
        comment = f"<!-- {header} -->\n" if header else ""
        return f'<?xml version="1.0"?>\n{comment}{ET.tostring(robot, encoding="unicode")}\n'

    def copy(self) -> RobotModel:
        return copy.deepcopy(self)


def inertia_problem(mass: float, inertia: Array) -> str | None:
    """A description of what makes (mass, inertia) unphysical, or None when it is valid."""
    if not np.isfinite(mass) or mass <= 0:
        return f"mass {mass} is not positive"
    if not np.allclose(inertia, inertia.T) or not np.all(np.isfinite(inertia)):
        return "inertia matrix is not symmetric and finite"
    moments = np.linalg.eigvalsh(inertia)
    if moments.min() <= INERTIA_TOLERANCE:
        return f"principal moments {np.round(moments, 8).tolist()} are not all positive"
    a, b, c = moments
    if a + b < c * (1 - 1e-9):
        return f"principal moments {np.round(moments, 8).tolist()} break the triangle inequality"
    return None


def _cycle(model: RobotModel, start: str) -> str:
    """The joint cycle above `start`, a link whose ancestors all have a parent joint."""
    parent = {j.child: j.parent for j in model.joints.values()}
    path = [start]
    while parent[path[-1]] not in path:
        path.append(parent[path[-1]])
    loop = path[path.index(parent[path[-1]]) :][::-1]
    return f"the joints form a cycle {' -> '.join([*loop, loop[0]])}; a URDF must be a tree"


def _check_tree(model: RobotModel) -> None:
    """One root link, every link reached from it through joints, no link the child of two."""
    parents: dict[str, str] = {}
    for joint in model.joints.values():
        if joint.child in parents:
            raise RobotModelError(
                f"{model.source}: link '{joint.child}' is the child of two joints, "
                f"'{parents[joint.child]}' and '{joint.name}'"
            )
        parents[joint.child] = joint.name
    reached = set(model.subtree(model.root))
    stray = [name for name in model.links if name not in reached]
    if stray:
        raise RobotModelError(f"{model.source}: {_cycle(model, stray[0])}")


# -- parsing ---------------------------------------------------------------------------------
def _floats(text: str | None, default: str, where: str, count: int) -> Array:
    words = (text or default).split()
    expected = "a finite number" if count == 1 else f"{count} finite numbers"
    try:
        values = np.array([float(v) for v in words])
    except ValueError:
        raise RobotModelError(f"{where}: expected {expected}, got {text!r}") from None
    if len(values) != count or not np.all(np.isfinite(values)):
        raise RobotModelError(f"{where}: expected {expected}, got {text!r}")
    return values


def _number(element: ET.Element, key: str, default: str, where: str) -> float:
    return float(_floats(element.get(key), default, f"{where} {element.tag} {key}", 1)[0])


def _origin(element: ET.Element | None, where: str) -> Array:
    if element is None:
        return np.eye(4)
    xyz = _floats(element.get("xyz"), "0 0 0", f"{where} origin xyz", 3)
    rpy = _floats(element.get("rpy"), "0 0 0", f"{where} origin rpy", 3)
    return make_transform(xyz, rpy)


def _shape(element: ET.Element, where: str) -> Shape | None:
    geometry = element.find("geometry")
    if geometry is None:
        return None
    color = element.find("material/color")
    rgba = None
    if color is not None:
        rgba = tuple(_floats(color.get("rgba"), "1 1 1 1", f"{where} color rgba", 4))
    return Shape(_origin(element.find("origin"), where), copy.deepcopy(geometry), rgba)


def _inertial(element: ET.Element | None, where: str) -> Inertial | None:
    if element is None:
        return None
    mass_el, inertia_el = element.find("mass"), element.find("inertia")
    if mass_el is None or inertia_el is None:
        raise RobotModelError(f"{where}: <inertial> needs <mass> and <inertia>")
    try:
        mass = float(mass_el.get("value", "nan"))
        i = {k: float(inertia_el.get(k, "0")) for k in ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")}
    except ValueError as exc:
        raise RobotModelError(f"{where}: inertial values must be numbers") from exc
    inertia = np.array(
        [
            [i["ixx"], i["ixy"], i["ixz"]],
            [i["ixy"], i["iyy"], i["iyz"]],
            [i["ixz"], i["iyz"], i["izz"]],
        ]
    )
    return Inertial(mass, _origin(element.find("origin"), where), inertia)


def parse_urdf(text: str, source: str = "<string>") -> RobotModel:
    """Parse URDF text; raise RobotModelError naming the source on malformed input."""
    try:
        root = ET.fromstring(text)
    except ET.ParseError as exc:
        raise RobotModelError(f"{source}: not valid XML ({exc})") from exc
    if root.tag != "robot":
        raise RobotModelError(f"{source}: the root element is <{root.tag}>, expected <robot>")
    links: dict[str, Link] = {}
    for el in root.findall("link"):
        name = el.get("name", "")
        where = f"{source}: link '{name}'"
        if not name or name in links:
            raise RobotModelError(f"{where}: {'a second link of that name' if name else 'no name'}")
        link = Link(name, _inertial(el.find("inertial"), where))
        link.visuals = [s for v in el.findall("visual") if (s := _shape(v, where))]
        link.collisions = [s for c in el.findall("collision") if (s := _shape(c, where))]
        links[name] = link
    joints: dict[str, Joint] = {}
    for el in root.findall("joint"):
        name = el.get("name", "")
        where = f"{source}: joint '{name}'"
        if not name or name in joints:
            raise RobotModelError(
                f"{where}: {'a second joint of that name' if name else 'no name'}"
            )
        if el.get("type") not in JOINT_TYPES:
            raise RobotModelError(
                f"{where}: type {el.get('type')!r} is not one of {', '.join(JOINT_TYPES)}"
            )
        parent, child = el.find("parent"), el.find("child")
        if parent is None or child is None:
            raise RobotModelError(f"{where}: needs <parent> and <child>")
        joint = Joint(
            name,
            el.get("type", ""),
            parent.get("link", ""),
            child.get("link", ""),
            _origin(el.find("origin"), where),
        )
        if joint.parent not in links or joint.child not in links:
            raise RobotModelError(f"{where}: connects unknown links {joint.parent}/{joint.child}")
        if joint.movable:
            _motion(joint, el, where)
        joints[name] = joint
    model = RobotModel(root.get("name", "robot"), links, joints, source)
    _check_tree(model)
    return model


def _motion(joint: Joint, element: ET.Element, where: str) -> None:
    """A movable joint's unit axis and its limits (finite numbers)."""
    axis = element.find("axis")
    xyz = _floats(axis.get("xyz") if axis is not None else None, "1 0 0", f"{where} axis xyz", 3)
    norm = float(np.linalg.norm(xyz))
    if not norm > 0:
        raise RobotModelError(f"{where}: axis xyz {axis.get('xyz')!r} has zero length")
    joint.axis = xyz / norm
    limit = element.find("limit")
    if limit is not None:
        joint.lower = _number(limit, "lower", "0", where)
        joint.upper = _number(limit, "upper", "0", where)
        joint.velocity = _number(limit, "velocity", "0", where)
        joint.effort = _number(limit, "effort", "0", where)


def load_urdf(path: Path) -> RobotModel:
    return parse_urdf(read_text(path, RobotModelError, "URDF"), str(path))


# -- writing ---------------------------------------------------------------------------------
def _num(value: float) -> str:
    value = float(value)
    if abs(value) < 1e-15:
        return "0"
    return repr(value)


def _vec(values: Array) -> str:
    return " ".join(_num(v) for v in values)


def _origin_xml(parent: ET.Element, transform: Array) -> None:
    ET.SubElement(
        parent,
        "origin",
        xyz=_vec(transform[:3, 3]),
        rpy=_vec(matrix_to_rpy(transform[:3, :3])),
    )


def _shape_xml(tag: str, shape: Shape) -> ET.Element:
    element = ET.Element(tag)
    _origin_xml(element, shape.origin)
    element.append(copy.deepcopy(shape.geometry))
    if shape.rgba is not None and tag == "visual":
        material = ET.SubElement(element, "material", name=f"rgba_{_vec(shape.rgba)}")
        ET.SubElement(material, "color", rgba=_vec(shape.rgba))
    return element


def _link_xml(link: Link) -> ET.Element:
    element = ET.Element("link", name=link.name)
    if link.inertial is not None:
        inertial = ET.SubElement(element, "inertial")
        _origin_xml(inertial, link.inertial.origin)
        ET.SubElement(inertial, "mass", value=_num(link.inertial.mass))
        i = link.inertial.inertia
        ET.SubElement(
            inertial,
            "inertia",
            ixx=_num(i[0, 0]),
            ixy=_num(i[0, 1]),
            ixz=_num(i[0, 2]),
            iyy=_num(i[1, 1]),
            iyz=_num(i[1, 2]),
            izz=_num(i[2, 2]),
        )
    element.extend(_shape_xml("visual", s) for s in link.visuals)
    element.extend(_shape_xml("collision", s) for s in link.collisions)
    return element


def _joint_xml(joint: Joint) -> ET.Element:
    element = ET.Element("joint", name=joint.name, type=joint.type)
    _origin_xml(element, joint.origin)
    ET.SubElement(element, "parent", link=joint.parent)
    ET.SubElement(element, "child", link=joint.child)
    if joint.movable:
        ET.SubElement(element, "axis", xyz=_vec(joint.axis))
        ET.SubElement(
            element,
            "limit",
            lower=_num(joint.lower),
            upper=_num(joint.upper),
            velocity=_num(joint.velocity),
            effort=_num(joint.effort),
        )
    return element
