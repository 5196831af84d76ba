"""iRonCub built from icub-models against the reference Mk1_1 facts."""

import numpy as np
import pytest

from motionkit.robot import THRUST_AXIS, ironcub
from motionkit.robot.urdf import RobotModel

REFERENCE_JOINTS = (
    "torso_pitch torso_roll torso_yaw "
    "l_shoulder_pitch l_shoulder_roll l_shoulder_yaw l_elbow "
    "r_shoulder_pitch r_shoulder_roll r_shoulder_yaw r_elbow "
    "l_hip_pitch l_hip_roll l_hip_yaw l_knee l_ankle_pitch l_ankle_roll "
    "r_hip_pitch r_hip_roll r_hip_yaw r_knee r_ankle_pitch r_ankle_roll"
).split()

# Computed with pinocchio 3.8 on the public iRonCub-Mk1_1 URDF (commit 36e4586), base at the
# origin; positions in metres in the root_link frame. Kept here so the test runs without ../shared.
REFERENCE_CONFIG = {
    "torso_pitch": 0.3,
    "torso_yaw": -0.2,
    "l_shoulder_pitch": -0.5,
    "l_shoulder_roll": 0.4,
    "l_elbow": 1.0,
    "r_shoulder_yaw": 0.3,
    "r_elbow": 0.7,
    "l_hip_pitch": 0.4,
    "l_knee": -0.8,
    "r_hip_roll": 0.2,
    "r_ankle_pitch": -0.3,
}
REFERENCE_AT_ZERO = {
    "l_sole": (0.007282, -0.070175, -0.619438),
    "r_sole": (0.007388, 0.070086, -0.619438),
    "l_sole_1": (-0.079218, -0.105929, -0.629938),
    "r_sole_3": (0.049946, 0.046411, -0.629938),
    "l_elbow_1": (-0.025684, -0.129633, -0.00176),
    "r_elbow_1": (-0.025685, 0.109619, -0.00176),
    "chest_l_jet_turbine": (0.110391, -0.17, -0.0321),
    "chest_r_jet_turbine": (0.110391, 0.17, -0.0321),
    "l_arm_jet_turbine": (-0.053184, -0.183245, -0.275517),
    "r_arm_jet_turbine": (-0.053185, 0.183245, -0.275517),
}
REFERENCE_AT_CONFIG = {
    "l_sole": (0.019084, -0.070175, -0.580329),
    "r_sole": (-0.011673, 0.168754, -0.60666),
    "l_sole_1": (-0.056499, -0.105929, -0.623685),
    "r_sole_3": (0.025882, 0.150043, -0.633521),
    "l_elbow_1": (-0.077004, -0.187054, 0.019227),
    "r_elbow_1": (-0.042966, 0.099213, -0.015133),
    "chest_l_jet_turbine": (0.145005, -0.143588, 0.011254),
    "chest_r_jet_turbine": (0.080475, 0.189635, -0.008707),
    "l_arm_jet_turbine": (-0.318172, -0.327342, -0.007812),
    "r_arm_jet_turbine": (-0.185538, 0.069191, -0.259861),
}
REFERENCE_COM = {
    "zero": (0.024856, -0.000349, -0.056334),
    "config": (-0.016714, 0.002801, -0.040628),
}
REFERENCE_THRUST_DIRECTION_AT_CONFIG = {  # -z of the jet frames
    "chest_l_jet_turbine": (-0.29552, 0.0, 0.955336),
    "l_arm_jet_turbine": (0.901203, 0.353938, 0.25012),
    "r_arm_jet_turbine": (0.314077, 0.308854, 0.897755),
}


def center_of_mass(model: RobotModel, q: dict[str, float]) -> np.ndarray:
    poses = model.link_poses(q)
    weighted = [
        (link.inertial.mass, (poses[name] @ link.inertial.origin)[:3, 3])
        for name, link in model.links.items()
        if link.inertial is not None
    ]
    return sum(m * p for m, p in weighted) / sum(m for m, _ in weighted)


def test_joints_mass_and_jets() -> None:
    robot = ironcub()
    assert robot.joint_names == tuple(REFERENCE_JOINTS)
    assert robot.total_mass == pytest.approx(44.7263, abs=0.05)
    assert [jet.frame for jet in robot.spec.jets] == [
        "chest_l_jet_turbine",
        "chest_r_jet_turbine",
        "l_arm_jet_turbine",
        "r_arm_jet_turbine",
    ]
    assert all(jet.t_max == 250.0 for jet in robot.spec.jets)
    assert robot.locked_joints == ("neck_pitch", "neck_roll", "neck_yaw")
    assert not any(
        name.startswith(("l_wrist", "r_wrist", "l_hand", "l_forearm")) for name in robot.model.links
    )


def test_jet_masses_and_limits() -> None:
    robot = ironcub()
    masses = {n: robot.model.links[n].inertial.mass for n in REFERENCE_AT_ZERO if "jet" in n}
    assert masses == pytest.approx(
        {
            "chest_l_jet_turbine": 1.91345,
            "chest_r_jet_turbine": 1.91345,
            "l_arm_jet_turbine": 1.69792,
            "r_arm_jet_turbine": 1.69792,
        }
    )
    limits = robot.limits
    index = REFERENCE_JOINTS.index
    # Placeholder 50000 rad/s of icub-models replaced; real leg values kept.
    assert limits.velocity[index("torso_pitch")] == 7.64
    assert limits.velocity[index("l_hip_pitch")] == 5.1
    assert limits.effort[index("l_hip_pitch")] == 55.5
    assert limits.lower[index("l_knee")] == pytest.approx(np.deg2rad(-124.0), abs=1e-3)


def test_jets_are_drawn_at_the_size_the_spec_gives() -> None:
    robot = ironcub()
    for jet in robot.spec.jets:
        assert (jet.length, jet.radius) == (0.35, 0.065)
        (visual,) = robot.model.links[jet.frame].visuals
        cylinder = visual.geometry.find("cylinder")
        assert float(cylinder.get("length")) == jet.length
        assert float(cylinder.get("radius")) == jet.radius
        np.testing.assert_allclose(visual.origin[:3, 3], [0.0, 0.0, -jet.length / 2])


@pytest.mark.parametrize(
    ("q", "expected", "com"),
    [
        ({}, REFERENCE_AT_ZERO, REFERENCE_COM["zero"]),
        (REFERENCE_CONFIG, REFERENCE_AT_CONFIG, REFERENCE_COM["config"]),
    ],
)
def test_kinematics_match_stored_reference(q: dict, expected: dict, com: tuple) -> None:
    model = ironcub().model
    poses = model.link_poses(q)
    for frame, position in expected.items():
        np.testing.assert_allclose(poses[frame][:3, 3], position, atol=1e-5, err_msg=frame)
    np.testing.assert_allclose(center_of_mass(model, q), com, atol=1e-5)


def test_thrust_points_up_at_zero_and_along_minus_z() -> None:
    poses = ironcub().model.link_poses()
    for jet in ironcub().spec.jets:
        np.testing.assert_allclose(poses[jet.frame][:3, :3] @ THRUST_AXIS, [0, 0, 1], atol=1e-6)
    poses = ironcub().model.link_poses(REFERENCE_CONFIG)
    for frame, direction in REFERENCE_THRUST_DIRECTION_AT_CONFIG.items():
        np.testing.assert_allclose(poses[frame][:3, :3] @ THRUST_AXIS, direction, atol=1e-5)


def test_every_link_inertia_is_valid() -> None:
    ironcub().model.check_inertias()  # raises on the Mk1_1 elbow defect if it slipped through
    elbow = ironcub().model.links["l_elbow_1"].inertial
    assert elbow.mass == pytest.approx(0.861052)
    # Uniform 0.18 x 0.06 x 0.06 m box: ixx = m (0.06^2 + 0.06^2) / 12.
    assert elbow.inertia[0, 0] == pytest.approx(0.861052 * 0.0072 / 12)


def test_against_reference_urdf_at_random_configurations(reference_urdf) -> None:
    pin = pytest.importorskip("pinocchio")
    robot = ironcub()
    models = [
        pin.buildModelFromUrdf(str(path), pin.JointModelFreeFlyer())
        for path in (robot.urdf_path(), reference_urdf)
    ]
    frames = [f for f in robot.spec.frames if f != "root_link"]
    rng = np.random.default_rng(7)
    configs = [{}] + [
        dict(
            zip(robot.joint_names, rng.uniform(robot.limits.lower, robot.limits.upper), strict=True)
        )
        for _ in range(20)
    ]
    for config in configs:
        results = []
        for model in models:
            data = model.createData()
            q = pin.neutral(model)
            for name, value in config.items():
                q[model.joints[model.getJointId(name)].idx_q] = value
            pin.framesForwardKinematics(model, data, q)
            poses = {f: data.oMf[model.getFrameId(f)] for f in frames}
            results.append((poses, pin.centerOfMass(model, data, q)))
        (ours, our_com), (ref, ref_com) = results
        for frame in frames:
            assert np.linalg.norm(ours[frame].translation - ref[frame].translation) < 1e-3, frame
            angle = np.linalg.norm(pin.log3(ours[frame].rotation.T @ ref[frame].rotation))
            assert np.degrees(angle) < 0.1, frame
        assert np.linalg.norm(our_com - ref_com) < 5e-3


def test_ironcub_stays_a_function_after_the_build() -> None:
    """The builder module must not shadow `motionkit.robot.ironcub` once it is imported."""
    import motionkit.robot

    ironcub()
    assert callable(motionkit.robot.ironcub)
