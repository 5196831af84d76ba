"""Batched forward kinematics against the one-configuration `link_poses`."""

import numpy as np

from motionkit.robot import ironcub
from motionkit.robot.kinematics import frame_poses


def test_frame_poses_match_link_poses_at_random_configurations() -> None:
    robot = ironcub()
    rng = np.random.default_rng(3)
    q = rng.uniform(robot.limits.lower, robot.limits.upper, (5, len(robot.joint_names)))
    frames = [*robot.spec.end_effectors, "chest_l_jet_turbine", "l_sole_3"]
    batched = frame_poses(robot.model, robot.joint_names, q, frames)
    for t in range(len(q)):
        single = robot.model.link_poses(dict(zip(robot.joint_names, q[t], strict=True)))
        for k, frame in enumerate(frames):
            np.testing.assert_allclose(batched[t, k], single[frame], atol=1e-12)


def test_toy_sole_position_by_hand(toy_robot) -> None:
    theta = np.array([0.0, 0.4, -0.7])
    q = np.zeros((3, len(toy_robot.joint_names)))
    q[:, toy_robot.joint_names.index("l_hip")] = theta
    sole = frame_poses(toy_robot.model, toy_robot.joint_names, q, ["l_sole"])[:, 0, :3, 3]
    # hip at (0, 0.1, -0.1); the sole 0.65 m below it along the rotated leg (axis y)
    expected = np.stack([-0.65 * np.sin(theta), np.full(3, 0.1), -0.1 - 0.65 * np.cos(theta)], 1)
    np.testing.assert_allclose(sole, expected, atol=1e-12)
