"""Build iRonCub from the `icub-models` iCubGazeboV2_5 URDF and the Mk1_1 differences."""

from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np

from motionkit.robot import mk1_1
from motionkit.robot.geometry import invert, make_transform
from motionkit.robot.spec import JetSpec, RobotSpec
from motionkit.robot.urdf import Inertial, Joint, Link, RobotModel, Shape, load_urdf

SOURCE_MODEL = "iCubGazeboV2_5"
JET_RGBA = (0.55, 0.55, 0.6, 1.0)


def icub_models_share() -> Path:
    """The `share` folder of the installed icub-models (meshes live in share/iCub/meshes)."""
    import icub_models

    return Path(icub_models.get_models_path()).parents[1]


def source_urdf() -> Path:
    import icub_models

    return Path(icub_models.get_model_file(SOURCE_MODEL))


def build_ironcub_model(spec: RobotSpec) -> RobotModel:
    """The iRonCub URDF tree: iCubGazeboV2_5 without forearms, with the Mk1_1 joint origins,
    inertials, jets (drawn as the spec's cylinders), chest marker and sole corners; massless
    leaf links other than the spec's frames are dropped; mesh paths point at the installed
    files."""
    model = load_urdf(source_urdf())
    poses_before = model.link_poses()
    for link in mk1_1.REMOVED_SUBTREES:
        model.remove_subtree(link)
    for name, origin in mk1_1.JOINT_ORIGINS.items():
        joint = model.joints[name]
        joint.origin = make_transform(origin.xyz, origin.rpy)
        joint.axis = np.array(origin.axis) / np.linalg.norm(origin.axis)
    for name, inertial in mk1_1.LINK_INERTIALS.items():
        model.links[name].inertial = _inertial(inertial)
    for name, added in mk1_1.ADDED_LINKS.items():
        link = Link(name, _inertial(added.inertial) if added.inertial else None)
        model.links[name] = link
        model.joints[added.joint] = Joint(
            added.joint, "fixed", added.parent, name, make_transform(added.xyz, added.rpy)
        )
    for jet in spec.jets:
        model.links[jet.frame].visuals = [_jet_cylinder(jet)]
    _drop_massless_leaves(model, keep=set(spec.frames))
    _carry_shapes(model, poses_before)
    _resolve_meshes(model, icub_models_share())
    model.name = "ironcub"
    model.source = f"icub-models {SOURCE_MODEL} + iRonCub-Mk1_1 changes"
    return model


def _inertial(values: mk1_1.LinkInertial) -> Inertial:
    ixx, ixy, ixz, iyy, iyz, izz = values.inertia
    inertia = np.array([[ixx, ixy, ixz], [ixy, iyy, iyz], [ixz, iyz, izz]])
    return Inertial(values.mass, make_transform(values.com_xyz, values.com_rpy), inertia)


def _jet_cylinder(jet: JetSpec) -> Shape:
    geometry = ET.Element("geometry")
    ET.SubElement(geometry, "cylinder", radius=repr(jet.radius), length=repr(jet.length))
    return Shape(make_transform(xyz=(0.0, 0.0, -jet.length / 2)), geometry, JET_RGBA)


def _drop_massless_leaves(model: RobotModel, keep: set[str]) -> None:
    while True:
        doomed = [
            name
            for name, link in model.links.items()
            if link.inertial is None
            and not model.child_joints(name)
            and name not in keep
            and name != model.root
        ]
        if not doomed:
            return
        for name in doomed:
            model.remove_subtree(name)


def _carry_shapes(model: RobotModel, poses_before: dict[str, np.ndarray]) -> None:
    """Move each link's meshes with the link: where a changed joint origin moved a link (the
    lower shoulders, say), its meshes translate by the same amount and keep their orientation."""
    poses_after = model.link_poses()
    for name, link in model.links.items():
        if name not in poses_before:
            continue
        before, after = poses_before[name], poses_after[name]
        shift = make_transform(xyz=after[:3, 3] - before[:3, 3])
        correction = invert(after) @ shift @ before
        for shape in link.visuals + link.collisions:
            shape.origin = correction @ shape.origin


def _resolve_meshes(model: RobotModel, share: Path) -> None:
    for link in model.links.values():
        for shape in link.visuals + link.collisions:
            mesh = shape.geometry.find("mesh")
            if mesh is not None and mesh.get("filename", "").startswith("package://"):
                relative = mesh.get("filename", "").removeprefix("package://")
                mesh.set("filename", str(share / relative))
