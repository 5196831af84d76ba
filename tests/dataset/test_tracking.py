"""Open-loop tracking windows in MuJoCo: a robot that stands keeps standing; one left in the air
without thrust falls in every window."""

import numpy as np
import pytest

from motionkit.dataset import Metadata, Trajectory
from motionkit.dataset.tracking import track_windows
from motionkit.robot import ironcub
from motionkit.robot.mjcf import standing_height

pytest.importorskip("mujoco")


def standing(lift: float, seconds: float = 2.0, rate: float = 50.0) -> Trajectory:
    robot = ironcub()
    posture = robot.spec.posture_angles()
    frames = round(seconds * rate)
    zeros = np.zeros((frames, 3))
    height = standing_height(robot, posture) + lift
    return Trajectory(
        time=np.arange(frames) / rate,
        base_position=np.tile([0.0, 0.0, height], (frames, 1)),
        base_orientation=np.tile([1.0, 0.0, 0.0, 0.0], (frames, 1)),
        joint_names=robot.joint_names,
        joint_positions=np.tile([posture[n] for n in robot.joint_names], (frames, 1)),
        joint_velocities=np.zeros((frames, len(robot.joint_names))),
        base_linear_velocity=zeros,
        base_angular_velocity=zeros,
        thrust=np.zeros((frames, len(robot.spec.jets))),
        contacts=np.full((frames, 2), lift == 0.0),
        jet_names=tuple(jet.name for jet in robot.spec.jets),
        foot_names=("left", "right"),
        metadata=Metadata(robot.name, robot.model_hash, "stand", "synthetic"),
    )


def test_standing_still_never_falls_and_free_fall_always_does() -> None:
    robot = ironcub()
    stand = track_windows(standing(0.0), robot, window=1.0, stride=0.5)
    assert stand.windows == 2 and stand.falls == 0  # starts 0 and 0.5 s: the clip spans 1.98 s
    assert stand.starts == pytest.approx((0.0, 0.5))
    # 1 m up without thrust: the base falls below 0.36 m (25 cm under standing) within 0.5 s
    air = track_windows(standing(1.0), robot, window=1.0, stride=0.5, feedforward=False)
    assert air.fall_share == 1.0 and all(air.fell)
