"""Capsules in the IK's URDF: pinocchio loads capsules where the capsules are."""

from dataclasses import replace

import numpy as np
import pytest

from motionkit.retarget.bodies import capsule_urdf, capsules, host_link
from motionkit.retarget.config import RetargetConfig
from motionkit.retarget.metrics import Kinematics
from motionkit.retarget.points import robot_points
from motionkit.robot import Robot, ironcub

pin = pytest.importorskip("pinocchio")


def test_pinocchio_loads_the_capsules(tmp_path) -> None:
    robot = ironcub()
    points = robot_points(robot, RetargetConfig().points)
    shapes, adjacent = capsules(robot, points)
    assert host_link(robot.model, shapes[0]) == "l_upper_leg"  # thigh: hip centre to knee
    assert frozenset(("l_thigh", "l_shank")) in adjacent
    path = tmp_path / "capsules.urdf"
    path.write_text(capsule_urdf(robot.model, shapes, "capsules"))
    model = pin.buildModelFromUrdf(str(path))
    geometry = pin.buildGeomFromUrdf(model, str(path), pin.COLLISION)
    data, geometry_data = model.createData(), pin.GeometryData(geometry)

    rng = np.random.default_rng(3)
    limits = robot.limits
    joints = rng.uniform(limits.lower, limits.upper, (3, len(robot.joint_names)))
    kin = Kinematics(robot, np.broadcast_to(np.eye(4), (3, 4, 4)), joints)
    hosts = [host_link(robot.model, c) for c in shapes]
    for t in range(3):
        q = pin.neutral(model)
        for name, value in zip(robot.joint_names, joints[t], strict=True):
            q[model.joints[model.getJointId(name)].idx_q] = value
        pin.updateGeometryPlacements(model, data, geometry, geometry_data, q)
        for capsule, host in zip(shapes, hosts, strict=True):
            index = _object_of(geometry, host, shapes, hosts, capsule)
            placement = geometry_data.oMg[index]
            shape = geometry.geometryObjects[index].geometry
            assert type(shape).__name__ == "Capsule", capsule.name
            half = shape.halfLength  # a capsule's segment: its rounded ends reach beyond
            axis = placement.rotation[:, 2]
            ends = [placement.translation - half * axis, placement.translation + half * axis]
            start, end = kin.point(capsule.start)[t], kin.point(capsule.end)[t]
            # the hip centre is a least-squares meeting point of axes that miss each other by
            # about 0.3 mm, so it is not exactly fixed in the thigh
            assert np.allclose(ends, [start, end], atol=1e-3), capsule.name
            assert shape.radius == capsule.radius


def test_jet_capsules_have_the_spec_size_and_unsized_jets_none() -> None:
    robot = ironcub()
    points = robot_points(robot, RetargetConfig().points)
    jets = {c.name: c for c in capsules(robot, points)[0] if c.name.startswith("jet_")}
    assert sorted(jets) == sorted(f"jet_{jet.name}" for jet in robot.spec.jets)
    for jet in robot.spec.jets:
        capsule = jets[f"jet_{jet.name}"]
        assert capsule.start.link == capsule.end.link == jet.frame
        np.testing.assert_array_equal(capsule.end.offset, [0.0, 0.0, -0.35])
        assert capsule.radius == 0.065
    unsized = replace(
        robot.spec, jets=tuple(replace(j, length=0.0, radius=0.0) for j in robot.spec.jets)
    )
    bare = Robot(robot.model, unsized, "iRonCub without jet sizes")
    assert not [c for c in capsules(bare, points)[0] if c.name.startswith("jet_")]


def _object_of(geometry, host, shapes, hosts, capsule) -> int:
    """Index of the capsule's collision object: the n-th of its host link."""
    nth = [c.name for c, h in zip(shapes, hosts, strict=True) if h == host].index(capsule.name)
    return geometry.getGeometryId(f"{host}_{nth}")
