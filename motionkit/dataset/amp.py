"""AMP features: the discriminator observation chi of a motion, resampled to the control rate.

chi_t = [base orientation (w, x, y, z), base linear velocity (base frame), base angular velocity
(base frame), joint positions, joint velocities, end-effector positions relative to the base in
the base frame (soles, then hands: iRonCub's arm jets), thrust per jet [N]].

The orientation is heading-free by default: the yaw of the robot's forward axis is removed, so
that walking north and walking east look alike to the discriminator (the policy follows
waypoints in every direction). `heading_free=False` keeps the world orientation.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np
from scipy.spatial.transform import Rotation, Slerp

from motionkit.dataset.trajectory import ARRAY_FIELDS, Trajectory
from motionkit.errors import DatasetError
from motionkit.robot import Robot
from motionkit.robot.geometry import from_rotation, quat_rotate_inverse, to_rotation
from motionkit.robot.kinematics import frame_poses


def feature_names(robot: Robot) -> list[str]:
    """One name per column of chi, in order."""
    names = [f"base_orientation.{c}" for c in "wxyz"]
    names += [f"base_linear_velocity.{c}" for c in "xyz"]
    names += [f"base_angular_velocity.{c}" for c in "xyz"]
    names += [f"joint_position.{j}" for j in robot.joint_names]
    names += [f"joint_velocity.{j}" for j in robot.joint_names]
    names += [f"{frame}.{c}" for frame in robot.spec.end_effectors for c in "xyz"]
    names += [f"thrust.{jet.name}" for jet in robot.spec.jets]
    return names


def remove_heading(robot: Robot, quats: np.ndarray) -> np.ndarray:
    """Base orientations with the heading removed: the yaw that turns the robot's forward axis
    from where it points at the identity orientation to where it points now (w >= 0)."""
    rotation = to_rotation(quats)
    forward = np.asarray(robot.spec.forward, dtype=float)
    facing = rotation.apply(forward)
    heading = np.arctan2(facing[:, 1], facing[:, 0]) - np.arctan2(forward[1], forward[0])
    return from_rotation(Rotation.from_rotvec(np.outer(-heading, [0, 0, 1])) * rotation)


def amp_features(trajectory: Trajectory, robot: Robot, *, heading_free: bool = True) -> np.ndarray:
    """chi for every frame of the trajectory: (T, len(feature_names(robot))) float32."""
    quats = trajectory.base_orientation.astype(float)
    orientation = remove_heading(robot, quats) if heading_free else quats
    linear = quat_rotate_inverse(quats, trajectory.base_linear_velocity.astype(float))
    angular = quat_rotate_inverse(quats, trajectory.base_angular_velocity.astype(float))
    poses = frame_poses(
        robot.model, trajectory.joint_names, trajectory.joint_positions, robot.spec.end_effectors
    )
    effectors = poses[:, :, :3, 3].reshape(trajectory.frames, -1)
    columns = [
        orientation,
        linear,
        angular,
        trajectory.joint_positions,
        trajectory.joint_velocities,
        effectors,
        trajectory.thrust,
    ]
    return np.concatenate(columns, axis=1).astype(np.float32)


def resample(trajectory: Trajectory, rate: float) -> Trajectory:
    """The trajectory at `rate` Hz from its first frame: linear interpolation for positions,
    velocities, thrust, contact forces and landmarks, slerp for the base orientation, the nearest
    frame for contacts."""
    if rate <= 0:
        raise DatasetError(f"resampling rate must be positive, got {rate}")
    if trajectory.frames < 2:
        raise DatasetError("cannot resample a clip of one frame")
    time = trajectory.time
    steps = int(np.floor((time[-1] - time[0]) * rate + 1e-9))
    new_time = time[0] + np.arange(steps + 1) / rate
    out: dict[str, np.ndarray] = {"time": new_time}
    for name in ARRAY_FIELDS:
        values = getattr(trajectory, name)
        if name == "time" or values is None:
            continue
        if name == "base_orientation":
            out[name] = from_rotation(Slerp(time, to_rotation(values))(new_time))
        elif name == "contacts":
            right = np.clip(np.searchsorted(time, new_time), 1, len(time) - 1)
            left_closer = new_time - time[right - 1] <= time[right] - new_time
            out[name] = values[np.where(left_closer, right - 1, right)]
        else:
            out[name] = _interpolate(time, values, new_time)
    return replace(trajectory, **out)


def _interpolate(time: np.ndarray, values: np.ndarray, new_time: np.ndarray) -> np.ndarray:
    index = np.clip(np.searchsorted(time, new_time, "right") - 1, 0, len(time) - 2)
    weight = (new_time - time[index]) / (time[index + 1] - time[index])
    weight = weight.reshape(-1, *[1] * (values.ndim - 1))  # over every axis of a frame
    return (1 - weight) * values[index] + weight * values[index + 1]


@dataclass(frozen=True)
class FeatureStats:
    """Per-column mean and standard deviation of chi (std floored at `floor`)."""

    mean: np.ndarray
    std: np.ndarray

    def normalize(self, features: np.ndarray) -> np.ndarray:
        return ((features - self.mean) / self.std).astype(np.float32)


def feature_stats(features: Sequence[np.ndarray], floor: float = 1e-3) -> FeatureStats:
    """Statistics over all frames of all clips; constant columns get std `floor`."""
    stacked = np.concatenate(features, axis=0).astype(float)
    return FeatureStats(stacked.mean(axis=0), np.maximum(stacked.std(axis=0), floor))


@dataclass(frozen=True)
class AmpPairs:
    """Transitions (chi_t, chi_t+1) of a dataset at the control rate, with the probability of
    drawing each (every clip gets its weight, spread evenly over its transitions)."""

    current: np.ndarray  # (N, D) float32
    following: np.ndarray  # (N, D) float32
    clip: np.ndarray  # (N,) index of the clip each pair comes from
    probability: np.ndarray  # (N,) sums to 1
    stats: FeatureStats
    names: tuple[str, ...]
    rate: float

    def sample(self, rng: np.random.Generator, count: int) -> tuple[np.ndarray, np.ndarray]:
        index = rng.choice(len(self.probability), size=count, p=self.probability)
        return self.current[index], self.following[index]


def amp_pairs(
    trajectories: Sequence[Trajectory],
    robot: Robot,
    rate: float,
    weights: Sequence[float] | None = None,
    *,
    heading_free: bool = True,
) -> AmpPairs:
    """Pairs of consecutive features of every clip resampled to `rate` (none across clips)."""
    if not trajectories:
        raise DatasetError("no clips to build AMP pairs from")
    weights = [1.0] * len(trajectories) if weights is None else list(weights)
    features, current, following, clip, probability = [], [], [], [], []
    for i, (trajectory, weight) in enumerate(zip(trajectories, weights, strict=True)):
        chi = amp_features(resample(trajectory, rate), robot, heading_free=heading_free)
        if len(chi) < 2:
            raise DatasetError(f"clip {i} is shorter than one control step at {rate} Hz")
        features.append(chi)
        current.append(chi[:-1])
        following.append(chi[1:])
        clip.append(np.full(len(chi) - 1, i))
        probability.append(np.full(len(chi) - 1, weight / (len(chi) - 1)))
    total = np.concatenate(probability)
    if not np.all(np.isfinite(total)) or total.sum() <= 0 or np.any(total < 0):
        raise DatasetError(f"clip weights must be non-negative with a positive sum, got {weights}")
    return AmpPairs(
        current=np.concatenate(current),
        following=np.concatenate(following),
        clip=np.concatenate(clip),
        probability=total / total.sum(),
        stats=feature_stats(features),
        names=tuple(feature_names(robot)),
        rate=rate,
    )
