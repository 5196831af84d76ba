"""`retarget(landmarks, rate, robot, config) -> Trajectory`: human motion onto the robot."""

from __future__ import annotations

import hashlib
import time as clock
from collections.abc import Callable
from dataclasses import dataclass, field
from functools import partial
from typing import Any

import numpy as np
from scipy.spatial.transform import Rotation

from motionkit.core.errors import RetargetError
from motionkit.dataset import Metadata, Source, Trajectory
from motionkit.dataset.physics import PhysicsReport, check_physics
from motionkit.mocap.naming import skeleton
from motionkit.retarget.balance import Pass, balance
from motionkit.retarget.config import RetargetConfig
from motionkit.retarget.ik import solve_motion
from motionkit.retarget.metrics import compute_metrics
from motionkit.retarget.points import Point, robot_points
from motionkit.retarget.targets import RobotGeometry, Targets, make_targets, slowed
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


@dataclass
class _Runs:
    """What the IK runs of one clip share: the IK's inputs, the progress callback (it counts
    frames over all the runs), the runs so far, and the physics of each motion checked (by
    content: the balance filter checks its first and best motions again)."""

    robot: Robot
    points: dict[str, Point]
    config: RetargetConfig
    source: Source
    targets: Targets  # as planned: the clip's landmarks and contacts
    progress: Callable[[int], None] | None
    solves: int = 0
    reports: dict[bytes, PhysicsReport] = field(default_factory=dict)
    convergence: dict[bytes, dict[str, float | int]] = field(default_factory=dict)


def retarget(
    landmarks: dict[str, Array],
    rate: float,
    robot: Robot,
    config: RetargetConfig,
    source: Source | None = None,
    progress: Callable[[int], None] | None = None,
    span: tuple[float, float] | None = None,
) -> tuple[Trajectory, Timings]:
    """The robot motion that follows a human's, made balanceable by the dynamic filter.

    The filter (`config.balance`) moves the base so that the centre of pressure stays in the
    support.

    Args:
        landmarks: the human's landmark positions, (T, 3) each [m], world frame, Z up;
            landmarks outside motionkit.mocap.LANDMARKS are not written into the clip.
        rate: frames per second of the landmarks [Hz].
        robot: the robot to retarget onto.
        config: the retargeting config.
        source: where the motion came from (the clip's metadata).
        progress: called with each frame's index once the IK solved it, counted on over the
            balance filter's passes (frame t of pass n: n T' + t).
        span: only [start, end] [s] of the human motion (both frames kept).

    Returns:
        The clip (T' frames, T' = T or the span's): base poses, joint positions [rad], the
        human low-passed and scaled to the robot (what it was retargeted to) as its landmarks,
        and its quality and physics figures (and what the filter changed) in the metadata;
        and the seconds spent per stage.
    """
    start = clock.perf_counter()
    if span is not None:
        landmarks = trimmed(landmarks, rate, span)
    points = robot_points(robot, config.points)
    targets = make_targets(
        landmarks, rate, RobotGeometry(robot, points, config.points.torso_frame), config
    )
    if config.slowdown != 1.0:
        targets = slowed(targets, config.slowdown)
    planned = clock.perf_counter()
    runs = _Runs(robot, points, config, source or Source(), targets, progress)
    base, joints = _solve(runs, targets)
    metrics: dict[str, Any] = {}
    goals = targets
    if config.balance.passes:
        before = compute_metrics(robot, targets, points, base, joints)
        physics_before = _check(runs, base, joints).summary()
        solve, check = partial(_solve, runs), partial(_check, runs)
        goals, base, joints, passes = balance(
            targets, solve, check, config.balance, first=(base, joints)
        )
        metrics |= _changes(before, physics_before, passes)
        metrics["balance_shift_max_m"] = round(
            float(np.abs(goals.root[:, :2, 3] - targets.root[:, :2, 3]).max()), 5
        )
    solved = clock.perf_counter()
    # tracking figures against what the IK followed: the balanced targets
    metrics = compute_metrics(robot, goals, points, base, joints) | metrics
    metrics |= runs.convergence[_key(base, joints)]
    metrics["scale"] = targets.scale
    metrics["slowdown"] = config.slowdown
    if span is not None:
        metrics["source_span_s"] = list(span)
    metrics["physics"] = _check(runs, base, joints).summary()
    measured = clock.perf_counter()
    trajectory = _trajectory(runs, base, joints, metrics)
    return trajectory, Timings(planned - start, solved - planned, measured - solved)


def _solve(runs: _Runs, goals: Targets) -> tuple[Array, Array]:
    """The IK on `goals`: base poses (T, 4, 4) and joint positions (T, J) [rad]."""
    offset = runs.solves * len(goals.time)
    runs.solves += 1
    progress = runs.progress
    step = None if progress is None else (lambda t: progress(offset + t))
    solution = solve_motion(runs.robot, goals, runs.points, runs.config, step)
    runs.convergence[_key(solution.base, solution.joints)] = solution.figures()
    return solution.base, solution.joints


def _key(base: Array, joints: Array) -> bytes:
    """A motion's identity (base poses, joints), by content."""
    return hashlib.sha256(base.tobytes() + joints.tobytes()).digest()


def _check(runs: _Runs, base: Array, joints: Array) -> PhysicsReport:
    """The physics of the motion (base poses (T, 4, 4), joints (T, J)), checked once."""
    key = _key(base, joints)
    if key not in runs.reports:
        runs.reports[key] = check_physics(_trajectory(runs, base, joints), runs.robot)
    return runs.reports[key]


def span_frames(rate: float, span: tuple[float, float]) -> tuple[int, int]:
    """The first and last frame (both kept) of `span` [s] in a motion at `rate` Hz."""
    return round(span[0] * rate), round(span[1] * rate)


def trimmed(
    landmarks: dict[str, Array], rate: float, span: tuple[float, float]
) -> dict[str, Array]:
    """The frames of `landmarks` (at `rate` Hz) from span[0] to span[1] s, both included."""
    frames = len(next(iter(landmarks.values())))
    duration = (frames - 1) / rate
    first, last = span_frames(rate, span)
    if last > frames - 1 + 1e-6 * rate or last - first < 1:
        raise RetargetError(
            f"trim [{span[0]}, {span[1]}] s does not fit the motion ({duration:.3f} s long)"
        )
    return {name: values[first : last + 1] for name, values in landmarks.items()}


def _changes(before: dict[str, Any], physics: dict[str, Any], passes: list[Pass]) -> dict[str, Any]:
    """What the balance filter changed: figures before it, and its largest base shift."""
    kept = ("feet_error_mean_m", "knees_error_mean_m", "elbows_error_mean_m", "foot_slide_p95_m_s")
    return {
        "balance_passes": len(passes) - 1,
        "balance_cop_inside_share_per_pass": [round(p.cop_inside_share, 4) for p in passes],
        **{f"before_balance_{k}": before[k] for k in kept},
        "before_balance_physics": {
            k: physics[k]
            for k in (
                "cop_inside_share",
                "cop_inside_share_single_support",
                "torque_within_share",
                "torque_within_share_single_support",
            )
        },
    }


def _trajectory(
    runs: _Runs, base: Array, joints: Array, metrics: dict[str, Any] | None = None
) -> Trajectory:
    """The clip of a solved motion: base poses (T, 4, 4), joint positions (T, J) [rad]."""
    robot, targets, time = runs.robot, runs.targets, runs.targets.time
    quats = from_rotation(Rotation.from_matrix(base[:, :3, :3]))
    names, parents = skeleton(list(targets.human))
    return Trajectory(
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
            kind=runs.config.kind,
            generator="retarget",
            source=runs.source,
            config=_plain(runs.config.to_dict()),
            metrics=metrics or {},
        ),
    )


def _plain(value: object) -> object:
    """Tuples as lists, so that the config survives a JSON round trip unchanged."""
    if isinstance(value, dict):
        return {k: _plain(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_plain(v) for v in value]
    return value
