"""AMP features: the discriminator observation chi of a motion, resampled to the control rate.

chi_t = [base orientation (w, x, y, z), base linear velocity (base frame), base angular velocity
(base frame), joint positions, joint velocities, end-effector positions relative to the base in
the base frame (soles, then hands: iRonCub's arm jets), thrust per jet [N]]: `FeatureLayout`,
the one definition of these blocks, their order and sizes, shared with the simulator's features
(`motionkit.train.amp`) and observation (`motionkit.train.env`).

The orientation is heading-free by default: the yaw of the robot's forward axis is removed, so
that walking north and walking east look alike to the discriminator (the policy follows
waypoints in every direction). `heading_free=False` keeps the world orientation.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from types import ModuleType
from typing import Any

import numpy as np
from scipy.spatial.transform import Rotation, Slerp

from motionkit.core.errors import DatasetError
from motionkit.dataset.trajectory import ARRAY_FIELDS, Trajectory
from motionkit.robot import Robot
from motionkit.robot.geometry import from_rotation, quat_rotate_inverse, to_rotation
from motionkit.robot.kinematics import frame_poses


@dataclass(frozen=True)
class FeatureLayout:
    """The blocks of chi in order, each with the names of its columns."""

    blocks: tuple[tuple[str, tuple[str, ...]], ...]

    @classmethod
    def of(cls, robot: Robot) -> FeatureLayout:
        def named(block: str, parts: Sequence[str]) -> tuple[str, tuple[str, ...]]:
            return block, tuple(f"{block}.{part}" for part in parts)

        effectors = tuple(f"{frame}.{c}" for frame in robot.spec.end_effectors for c in "xyz")
        return cls(
            (
                named("base_orientation", "wxyz"),
                named("base_linear_velocity", "xyz"),
                named("base_angular_velocity", "xyz"),
                named("joint_position", robot.joint_names),
                named("joint_velocity", robot.joint_names),
                ("end_effectors", effectors),
                named("thrust", [jet.name for jet in robot.spec.jets]),
            )
        )

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(name for _, columns in self.blocks for name in columns)

    @property
    def size(self) -> int:
        return sum(len(columns) for _, columns in self.blocks)

    def slice(self, block: str) -> slice:
        """The columns of `block` in chi."""
        start = 0
        for name, columns in self.blocks:
            if name == block:
                return slice(start, start + len(columns))
            start += len(columns)
        raise KeyError(block)

    def join(self, parts: Mapping[str, Any], xp: ModuleType = np) -> Any:
        """chi from its blocks (arrays whose last axis is the block's columns), concatenated in
        order along the last axis by `xp` (numpy or jax.numpy)."""
        order = [name for name, _ in self.blocks]
        if set(parts) != set(order):
            raise ValueError(f"feature blocks {sorted(parts)}, the layout has {order}")
        for name, columns in self.blocks:
            if parts[name].shape[-1] != len(columns):
                raise ValueError(
                    f"feature block {name} has {parts[name].shape[-1]} columns, not {len(columns)}"
                )
        return xp.concatenate([parts[name] for name in order], axis=-1)


def feature_names(robot: Robot) -> list[str]:
    """One name per column of chi, in order.

    Each name is its block and column: "base_orientation.w", "joint_position.<joint>",
    "<frame>.x" for an end effector, "thrust.<jet>" (see `FeatureLayout`).

    Args:
        robot: the robot whose joints, end effectors and jets make the columns.

    Returns:
        The D names, D = 10 + 2 J + 3 E + N for J joints, E end effectors and N jets.
    """
    return list(FeatureLayout.of(robot).names)


def remove_heading(robot: Robot, quats: np.ndarray) -> np.ndarray:
    """Base orientations with the heading removed: the yaw that turns the robot's forward axis
    from where it points at the identity orientation to where it points now (w >= 0)."""
    rotation = to_rotation(quats)
    forward = np.asarray(robot.spec.forward, dtype=float)
    facing = rotation.apply(forward)
    heading = np.arctan2(facing[:, 1], facing[:, 0]) - np.arctan2(forward[1], forward[0])
    return from_rotation(Rotation.from_rotvec(np.outer(-heading, [0, 0, 1])) * rotation)


def amp_features(trajectory: Trajectory, robot: Robot, *, heading_free: bool = True) -> np.ndarray:
    """chi for every frame of the trajectory: (T, len(feature_names(robot))) float32.

    Args:
        trajectory: the clip, T frames of the robot's joints and jets.
        robot: the robot of the clip; its spec names the end effectors and forward axis.
        heading_free: remove the yaw of the robot's forward axis from the base orientation;
            False keeps the world orientation.

    Returns:
        chi (T, D) float32: base orientation (w, x, y, z), base linear [m/s] and angular
        [rad/s] velocity in the base frame, joint positions [rad] and velocities [rad/s],
        end-effector positions relative to the base in the base frame [m], thrust [N].
    """
    quats = trajectory.base_orientation.astype(float)
    orientation = remove_heading(robot, quats) if heading_free else quats
    linear = quat_rotate_inverse(quats, trajectory.base_linear_velocity.astype(float))
    angular = quat_rotate_inverse(quats, trajectory.base_angular_velocity.astype(float))
    poses = frame_poses(
        robot.model, trajectory.joint_names, trajectory.joint_positions, robot.spec.end_effectors
    )
    chi = FeatureLayout.of(robot).join(
        {
            "base_orientation": orientation,
            "base_linear_velocity": linear,
            "base_angular_velocity": angular,
            "joint_position": trajectory.joint_positions,
            "joint_velocity": trajectory.joint_velocities,
            "end_effectors": poses[:, :, :3, 3].reshape(trajectory.frames, -1),
            "thrust": trajectory.thrust,
        }
    )
    return chi.astype(np.float32)


def resample(trajectory: Trajectory, rate: float) -> Trajectory:
    """The trajectory at `rate` Hz from its first frame.

    Linear interpolation for positions, velocities, thrust, contact forces and landmarks, slerp
    for the base orientation, the nearest frame for contacts. The new frames are spaced 1 / rate
    apart and end at or before the last frame; names and metadata are kept.

    Args:
        trajectory: the clip, two frames or more.
        rate: frames per second of the result [Hz].

    Returns:
        The resampled clip.

    Raises:
        DatasetError: a rate that is not positive, or a clip of one frame.
    """
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
    """Pairs of consecutive features of every clip resampled to `rate` (none across clips).

    Args:
        trajectories: the clips, each of the robot's joints and jets.
        robot: the robot of the clips.
        rate: the control rate the clips are resampled to [Hz].
        weights: each clip's share of the draws, non-negative with a positive sum, one per
            clip (None: 1 each); a clip's weight is spread evenly over its transitions.
        heading_free: as in `amp_features`.

    Returns:
        The N transitions (chi_t, chi_t+1), each (N, D) float32, with the clip index and the
        drawing probability (summing to 1) of each, the features' per-column mean and std over
        every resampled frame, the column names and the rate.

    Raises:
        DatasetError: no clips, a clip shorter than one control step at `rate`, weights with a
            negative or non-finite value or no positive sum, or a clip `resample` refuses.
    """
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
