"""A synthetic motion with known velocities, for tests, benchmarks and examples.

The base moves on a circle at `speed` m/s while turning at `turn_rate` rad/s about world z and
bobbing 2 cm at 1 Hz about the robot's standing base height; every joint swings sinusoidally
inside a quarter of its range; velocities are the exact derivatives. Contacts alternate with
the sign of a 1 Hz gait phase.
"""

from __future__ import annotations

import numpy as np

from motionkit.dataset.trajectory import Metadata, Source, Trajectory
from motionkit.robot import Robot
from motionkit.robot.mjcf import standing_height


def synthetic_trajectory(
    robot: Robot,
    seconds: float,
    rate: float = 120.0,
    *,
    speed: float = 0.5,
    turn_rate: float = 0.3,
    thrust: float = 0.0,
    seed: int = 0,
    kind: str = "walk",
    base_height: float | None = None,
) -> Trajectory:
    """`seconds` of motion at `rate` Hz; `thrust` [N] per jet, with a 10 % 0.5 Hz ripple; the
    base bobs about `base_height` [m] (default: the robot's standing height)."""
    rng = np.random.default_rng(seed)
    time = np.arange(round(seconds * rate)) / rate
    yaw = turn_rate * time
    radius = speed / turn_rate
    bob = 2 * np.pi * 1.0
    height = (
        standing_height(robot, robot.spec.posture_angles()) if base_height is None else base_height
    )
    base_position = np.stack(
        [radius * np.sin(yaw), radius * (1 - np.cos(yaw)), height + 0.02 * np.sin(bob * time)],
        axis=1,
    )
    base_linear_velocity = np.stack(
        [speed * np.cos(yaw), speed * np.sin(yaw), 0.02 * bob * np.cos(bob * time)], axis=1
    )
    zeros = np.zeros_like(time)
    base_orientation = np.stack([np.cos(yaw / 2), zeros, zeros, np.sin(yaw / 2)], axis=1)
    base_angular_velocity = np.stack([zeros, zeros, np.full_like(time, turn_rate)], axis=1)

    limits = robot.limits
    middle = 0.5 * (limits.lower + limits.upper)
    amplitude = 0.125 * (limits.upper - limits.lower)
    frequency = 2 * np.pi * rng.uniform(0.3, 1.5, len(middle))
    phase = rng.uniform(0, 2 * np.pi, len(middle))
    angle = frequency * time[:, None] + phase
    joint_positions = middle + amplitude * np.sin(angle)
    joint_velocities = amplitude * frequency * np.cos(angle)

    jets = len(robot.spec.jets)
    ripple = 1 + 0.1 * np.sin(2 * np.pi * 0.5 * time)
    gait = np.sin(2 * np.pi * 1.0 * time)
    feet = len(robot.spec.feet)
    contacts = np.stack([gait >= 0 if i % 2 == 0 else gait < 0 for i in range(feet)], axis=1)
    return Trajectory(
        time=time,
        base_position=base_position,
        base_orientation=base_orientation,
        joint_names=robot.joint_names,
        joint_positions=joint_positions,
        joint_velocities=joint_velocities,
        base_linear_velocity=base_linear_velocity,
        base_angular_velocity=base_angular_velocity,
        thrust=np.outer(thrust * ripple, np.ones(jets)),
        contacts=contacts.reshape(len(time), feet),
        jet_names=tuple(jet.name for jet in robot.spec.jets),
        foot_names=tuple(foot.side for foot in robot.spec.feet),
        metadata=Metadata(
            robot=robot.name,
            robot_hash=robot.model_hash,
            kind=kind,
            generator="synthetic",
            source=Source(clip=f"synthetic-{seed}", licence="CC0-1.0"),
            config={
                "seconds": seconds,
                "rate": rate,
                "speed": speed,
                "turn_rate": turn_rate,
                "thrust": thrust,
                "seed": seed,
            },
        ),
    )
