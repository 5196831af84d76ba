"""`retarget(landmarks, rate, robot, config) -> Trajectory`: human motion onto the robot."""

from __future__ import annotations

import time as clock
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from scipy.spatial.transform import Rotation

from motionkit.dataset import Metadata, Source, Trajectory
from motionkit.mocap.naming import skeleton
from motionkit.retarget.config import RetargetConfig
from motionkit.retarget.ik import solve_motion
from motionkit.retarget.metrics import compute_metrics
from motionkit.retarget.points import robot_points
from motionkit.retarget.targets import RobotGeometry, make_targets
from motionkit.robot import Robot
from motionkit.robot.geometry import Array, angular_velocity, from_rotation

CMU_LICENCE = "CMU Graphics Lab Motion Capture Database terms: free for research and commercial use"
CMU_ACKNOWLEDGEMENT = (
    "The data used in this project was obtained from mocap.cs.cmu.edu. "
    "The database was created with funding from NSF EIA-0196217."
)


@dataclass(frozen=True)
class Timings:
    """Seconds spent per stage."""

    targets: float
    ik: float
    metrics: float


def retarget(
    landmarks: dict[str, Array],
    rate: float,
    robot: Robot,
    config: RetargetConfig,
    source: Source | None = None,
    progress: Callable[[int], None] | None = None,
) -> tuple[Trajectory, Timings]:
    """The robot motion that follows human landmarks (world positions [m], Z up, at `rate` Hz),
    with its quality metrics in the metadata, and the human (low-passed, scaled to the robot:
    what it was retargeted to) as the clip's landmarks; landmarks outside
    motionkit.mocap.LANDMARKS are not written."""
    start = clock.perf_counter()
    points = robot_points(robot, config.points)
    targets = make_targets(
        landmarks, rate, RobotGeometry(robot, points, config.points.torso_frame), config
    )
    planned = clock.perf_counter()
    base, joints = solve_motion(robot, targets, points, config, progress)
    solved = clock.perf_counter()
    metrics = compute_metrics(robot, targets, points, base, joints)
    metrics["scale"] = targets.scale
    measured = clock.perf_counter()

    time = targets.time
    quats = from_rotation(Rotation.from_matrix(base[:, :3, :3]))
    names, parents = skeleton(list(targets.human))
    trajectory = Trajectory(
        time=time,
        base_position=base[:, :3, 3],
        base_orientation=quats,
        joint_names=robot.joint_names,
        joint_positions=joints,
        joint_velocities=np.gradient(joints, time, axis=0),
        base_linear_velocity=np.gradient(base[:, :3, 3], time, axis=0),
        base_angular_velocity=angular_velocity(time, quats),
        thrust=np.zeros((len(time), len(robot.spec.jets))),
        contacts=targets.contacts,
        jet_names=tuple(jet.name for jet in robot.spec.jets),
        foot_names=tuple(foot.side for foot in robot.spec.feet),
        landmark_names=names,
        landmark_parents=parents,
        landmarks=np.stack([targets.human[name] for name in names], axis=1),
        metadata=Metadata(
            robot=robot.name,
            robot_hash=robot.model_hash,
            kind=config.kind,
            generator="retarget",
            source=source or Source(),
            config=_plain(config.to_dict()),
            metrics=metrics,
        ),
    )
    return trajectory, Timings(planned - start, solved - planned, measured - solved)


def _plain(value: object) -> object:
    """Tuples as lists, so that the config survives a JSON round trip unchanged."""
    if isinstance(value, dict):
        return {k: _plain(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_plain(v) for v in value]
    return value
