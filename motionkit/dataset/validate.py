"""`motionkit dataset validate`: every check a clip must pass, as a report; `read_valid` for
the commands that refuse a clip failing one (export, view) and `read_sound` for those that
need only a sound file (info)."""

from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from motionkit.core.errors import DatasetError, MotionkitError
from motionkit.dataset.clip import corner_names, read
from motionkit.dataset.physics import PhysicsConfig, check_physics
from motionkit.dataset.trajectory import Trajectory
from motionkit.robot import Robot
from motionkit.robot.geometry import angular_velocity

QUATERNION_TOLERANCE = 1e-3  # | |q| - 1 |
LIMIT_TOLERANCE = 1e-3  # rad beyond a position limit; relative beyond a velocity limit
# A simulated clip (generator "rollout") may go further: MuJoCo's joint limits are soft
# constraints (solref 0.02 s by default), and a limb swinging into its stop overshoots it by
# about 0.01 rad before it is pushed back (0.0122 rad for an elbow in a CPU walking run). Its
# joints have no velocity limit either: beyond one is a warning there (7 rad/s for a hip of a
# random policy's fall).
SIMULATED_LIMIT_TOLERANCE = 0.03  # rad
# A stored velocity agrees with the differentiated positions when the RMS difference is below
# RELATIVE x RMS(velocity) + ABSOLUTE (central differences of a smooth motion differ by
# O(dt^2); rollouts log instantaneous velocities).
VELOCITY_RELATIVE, VELOCITY_ABSOLUTE = 0.1, 0.05


READ_CHECK = "read (schema, metadata, CRCs)"
MODEL_CHECK = "robot model"


@dataclass(frozen=True)
class Check:
    name: str
    ok: bool
    detail: str
    warning: bool = False  # a failed warning is reported but does not fail the clip


def validate_clip(
    path: Path, robot: Robot | None, physics: PhysicsConfig | None = None
) -> list[Check]:
    """Read the clip (schema, metadata, CRCs) and check its values; `robot` None skips the
    checks against a robot (its joints and limits, and the physics check, whose thresholds
    `physics` sets: warnings)."""
    trajectory, checks = _checks(path, robot)
    if trajectory is not None and robot is not None and all(c.ok for c in checks):
        checks.append(check_physics_warnings(trajectory, robot, physics or PhysicsConfig()))
    return checks


def read_sound(path: Path) -> Trajectory:
    """The clip, or a DatasetError naming it unless it reads (schema, metadata, CRCs) with
    increasing times, finite values and unit quaternions."""
    return _refuse_failed(path, *_read_and_check(path))


def read_valid(path: Path, robot: Robot, *, other_model: bool = False) -> Trajectory:
    """The clip, or a DatasetError naming it and the first check of `dataset validate` it
    fails (the physics warnings aside); `other_model` lets a clip made for another model of
    the robot (the same names) pass."""
    trajectory, checks = _checks(path, robot)
    return _refuse_failed(
        path, trajectory, [c for c in checks if not other_model or c.name != MODEL_CHECK]
    )


def _read_and_check(path: Path) -> tuple[Trajectory | None, list[Check]]:
    """The clip (None when unreadable) and the checks of a sound file."""
    try:
        trajectory = read(path)
    except MotionkitError as exc:
        return None, [Check(READ_CHECK, False, str(exc))]
    checks = [Check(READ_CHECK, True, f"{trajectory.frames} frames")]
    checks += [check_time(trajectory), check_finite(trajectory), check_quaternions(trajectory)]
    return trajectory, checks


def _checks(path: Path, robot: Robot | None) -> tuple[Trajectory | None, list[Check]]:
    """The clip and every check but the physics warnings."""
    trajectory, checks = _read_and_check(path)
    if trajectory is not None:
        if trajectory.frames > 2 and checks[1].ok and checks[2].ok:  # increasing, finite data
            checks += check_velocities(trajectory)
        if robot is not None:
            checks += check_robot(trajectory, robot)
    return trajectory, checks


def _refuse_failed(path: Path, trajectory: Trajectory | None, checks: list[Check]) -> Trajectory:
    for check in checks:
        if check.name == READ_CHECK and not check.ok:
            raise DatasetError(check.detail)  # names the file already
        if not check.ok and not check.warning:
            raise DatasetError(
                f"{path}: {check.name}: {check.detail} (see `motionkit dataset validate`)"
            )
    assert trajectory is not None  # an unreadable clip fails its read check
    return trajectory


def check_physics_warnings(trajectory: Trajectory, robot: Robot, config: PhysicsConfig) -> Check:
    """The physics check's shortfalls against the config's thresholds, as a warning."""
    name = "physics (torques, CoP, friction, residual)"
    try:
        report = check_physics(trajectory, robot, config)
    except MotionkitError as exc:
        return Check(name, False, f"not checked: {exc}", warning=True)
    shortfalls = report.warnings()
    figures = report.summary()
    detail = (
        "; ".join(shortfalls)
        if shortfalls
        else (
            f"torques within limits {figures['torque_within_share']}, CoP inside "
            f"{figures['cop_inside_share']}, explained {figures['explained_share']}"
        )
    )
    return Check(name, not shortfalls, detail, warning=True)


def check_time(trajectory: Trajectory) -> Check:
    steps = np.diff(trajectory.time)
    if trajectory.time[0] < 0:
        return Check("time", False, f"starts at {trajectory.time[0]} s (< 0)")
    if np.any(steps <= 0):
        frame = int(np.argmax(steps <= 0)) + 1
        return Check("time", False, f"not strictly increasing at frame {frame}")
    return Check("time", True, f"{trajectory.duration:.3f} s at {trajectory.rate:.2f} Hz")


def check_finite(trajectory: Trajectory) -> Check:
    for name, values in trajectory.arrays().items():
        if values.dtype != bool and not np.all(np.isfinite(values)):
            frame = int(np.argwhere(~np.isfinite(values))[0][0])
            return Check("finite values", False, f"{name} is not finite at frame {frame}")
    return Check("finite values", True, "all arrays finite")


def check_quaternions(trajectory: Trajectory) -> Check:
    error = np.abs(np.linalg.norm(trajectory.base_orientation.astype(float), axis=1) - 1)
    worst = int(np.argmax(error))
    ok = bool(error[worst] <= QUATERNION_TOLERANCE)
    return Check(
        "unit quaternions", ok, f"largest | |q| - 1 | = {error[worst]:.2e} at frame {worst}"
    )


def _agreement(name: str, stored: np.ndarray, derived: np.ndarray, columns: list[str]) -> Check:
    """Compare stored velocities with differentiated positions on the interior frames."""
    stored, derived = stored[1:-1].astype(float), derived[1:-1]
    error = np.sqrt(np.mean((stored - derived) ** 2, axis=0))
    allowed = VELOCITY_RELATIVE * np.sqrt(np.mean(stored**2, axis=0)) + VELOCITY_ABSOLUTE
    worst = int(np.argmax(error / allowed))
    detail = (
        f"worst {columns[worst]}: RMS difference {error[worst]:.3g} (allowed {allowed[worst]:.3g})"
    )
    return Check(name, bool(np.all(error <= allowed)), detail)


def check_velocities(trajectory: Trajectory) -> list[Check]:
    time = trajectory.time
    joints = np.gradient(trajectory.joint_positions.astype(float), time, axis=0)
    base = np.gradient(trajectory.base_position.astype(float), time, axis=0)
    omega = angular_velocity(time, trajectory.base_orientation.astype(float))
    return [
        _agreement(
            "joint velocities = d/dt joint positions",
            trajectory.joint_velocities,
            joints,
            list(trajectory.joint_names),
        ),
        _agreement(
            "base linear velocity = d/dt base position",
            trajectory.base_linear_velocity,
            base,
            ["x", "y", "z"],
        ),
        _agreement(
            "base angular velocity = from d/dt orientation",
            trajectory.base_angular_velocity,
            omega,
            ["x", "y", "z"],
        ),
    ]


def check_names(trajectory: Trajectory, robot: Robot) -> Check | None:
    """The first of joint, jet and foot names that is not the robot's, or None."""
    expected = {
        "joint": robot.joint_names,
        "jet": tuple(jet.name for jet in robot.spec.jets),
        "foot": tuple(foot.side for foot in robot.spec.feet),
    }
    for kind, names in expected.items():
        found = getattr(trajectory, f"{kind}_names")
        if found != names:
            missing = sorted(set(names) - set(found))
            extra = sorted(set(found) - set(names))
            detail = (
                f"missing {missing}, unknown {extra}" if missing or extra else "different order"
            )
            return Check(f"{kind} names of {robot.name}", False, detail)
    return None


def check_robot(trajectory: Trajectory, robot: Robot) -> list[Check]:
    wrong = check_names(trajectory, robot)
    if wrong is not None:
        return [wrong]
    meta = trajectory.metadata
    counts = f"{len(robot.joint_names)} joints, {len(robot.spec.jets)} jets"
    checks = [
        Check(f"joint, jet and foot names of {robot.name}", True, counts),
        Check(
            MODEL_CHECK,
            meta.robot_hash == robot.model_hash,
            f"clip made for {meta.robot} model {meta.robot_hash}; this model {robot.model_hash}",
        ),
    ]
    limits = robot.limits
    q = trajectory.joint_positions.astype(float)
    beyond = np.maximum(limits.lower - q, q - limits.upper)
    simulated = meta.generator == "rollout"
    tolerance = SIMULATED_LIMIT_TOLERANCE if simulated else LIMIT_TOLERANCE
    name = "joint position limits" + (" (soft in simulation)" if simulated else "")
    checks.append(_limit_check(name, beyond, tolerance, "rad", trajectory))
    speed = np.abs(trajectory.joint_velocities.astype(float)) - limits.velocity
    velocity = _limit_check(
        "joint velocity limits", speed, LIMIT_TOLERANCE * limits.velocity, "rad/s", trajectory
    )
    if simulated:  # the simulator's joints have no velocity limit: a falling limb passes one
        velocity = replace(velocity, name=f"{velocity.name} (not simulated)", warning=True)
    checks.append(velocity)
    t_max = np.array([jet.t_max for jet in robot.spec.jets])
    thrust = trajectory.thrust.astype(float)
    over = np.maximum(-thrust, thrust - t_max)
    checks.append(_limit_check("thrust within 0..T_max", over, 1e-3, "N", trajectory, "jet_names"))
    if trajectory.contact_forces is not None:
        checks.append(check_corners(trajectory, robot))
    if trajectory.throttle is not None:
        throttle = trajectory.throttle.astype(float)
        over = np.maximum(-throttle, throttle - 100.0)
        checks.append(
            _limit_check("throttle within 0..100 %", over, 1e-3, "%", trajectory, "jet_names")
        )
    return checks


def check_corners(trajectory: Trajectory, robot: Robot) -> Check:
    """The rows of contact_forces are the robot's sole corners, in spec order."""
    expected = corner_names(robot)
    if trajectory.corner_names == expected:
        return Check(f"sole corners of {robot.name}", True, f"{len(expected)} corners")
    detail = f"{list(trajectory.corner_names)}, expected {list(expected)}"
    return Check(f"sole corners of {robot.name}", False, detail)


def _limit_check(
    name: str,
    beyond: np.ndarray,
    tolerance: float | np.ndarray,
    unit: str,
    trajectory: Trajectory,
    names: str = "joint_names",
) -> Check:
    violations = beyond > tolerance
    if not np.any(violations):
        return Check(name, True, f"largest excess {max(float(beyond.max()), 0.0) + 0.0:.3g} {unit}")
    frame, column = np.unravel_index(int(np.argmax(beyond)), beyond.shape)
    label = getattr(trajectory, names)[column]
    return Check(
        name,
        False,
        f"{int(violations.any(axis=1).sum())} frames beyond; worst {label} by "
        f"{beyond[frame, column]:.3g} {unit} at frame {frame}",
    )
