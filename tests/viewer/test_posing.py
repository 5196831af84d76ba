"""Link poses, centre of mass and quaternions of the viewer against motionkit's own kinematics."""

import numpy as np
from scipy.spatial.transform import Rotation

from motionkit.robot import ironcub
from motionkit.viewer.posing import LinkPoser, matrices_to_quats, quat_to_matrix


def test_poses_match_the_robot_model() -> None:
    robot = ironcub()
    poser = LinkPoser(robot)
    rng = np.random.default_rng(1)
    q = rng.uniform(robot.limits.lower, robot.limits.upper)
    base = np.array([0.3, -0.2, 0.7])
    rotation = Rotation.from_rotvec([0.2, -0.4, 1.1])
    x, y, z, w = rotation.as_quat()
    poses = poser.poses(base, np.array([w, x, y, z]), q)
    world = np.eye(4)
    world[:3, :3], world[:3, 3] = rotation.as_matrix(), base
    expected = robot.model.link_poses(dict(zip(robot.joint_names, q, strict=True)))
    assert set(poser.links) == set(expected)
    for link, pose in expected.items():
        np.testing.assert_allclose(poses[poser.index[link]], world @ pose, atol=1e-12)


def test_centre_of_mass_by_hand(toy_robot) -> None:
    """The toy biped at zero joint angles, base at (1, 2, 3): link centres at the link origins,
    pelvis 4 kg at 0, arm 0.5 kg at (0, .15, .1), elbow 0.5 kg at (0, .15, -.1), jets 1 kg at
    y = +-0.1, thighs 1 kg at z = -0.1, shins 0.5 kg at -0.4, feet 0.5 kg at -0.7 (y = +-0.1)."""
    poser = LinkPoser(toy_robot)
    poses = poser.poses(np.array([1.0, 2.0, 3.0]), np.array([1.0, 0, 0, 0]), np.zeros(7))
    assert poser.total_mass == 11.0
    y = 0.5 * 0.15 + 0.5 * 0.15  # everything else cancels left to right
    z = 0.5 * 0.1 - 0.5 * 0.1 + 2 * (1.0 * -0.1 + 0.5 * -0.4 + 0.5 * -0.7)
    np.testing.assert_allclose(poser.com(poses), [1.0, 2.0 + y / 11, 3.0 + z / 11], atol=1e-12)


def test_quaternions_round_trip() -> None:
    rotations = Rotation.random(500, random_state=3)
    # include the hard cases: identity and half turns about each axis
    extra = Rotation.from_rotvec(np.pi * np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1.0]]))
    rotations = Rotation.concatenate([rotations, extra])
    quats = matrices_to_quats(rotations.as_matrix())
    x, y, z, w = rotations.as_quat().T
    expected = np.stack([w, x, y, z], 1)
    expected *= np.where(expected[:, :1] < 0, -1, 1)
    # q and -q are the same rotation; the w >= 0 sign leaves w = 0 cases ambiguous
    same = np.abs(np.sum(quats * expected, axis=1))
    np.testing.assert_allclose(same, 1.0, atol=1e-12)
    for quat, matrix in zip(quats, rotations.as_matrix(), strict=True):
        np.testing.assert_allclose(quat_to_matrix(quat), matrix, atol=1e-12)
