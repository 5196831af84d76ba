"""A solution as a dataset clip (resampled to the dataset rate) plus the knots themselves."""

from __future__ import annotations

import io
import json
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
from scipy.interpolate import PchipInterpolator
from scipy.spatial.transform import RotationSpline

from motionkit.dataset import Metadata, Source, Trajectory, corner_names, encode
from motionkit.dataset.physics import PhysicsConfig, check_physics
from motionkit.files.outputs import write_files
from motionkit.robot import Robot
from motionkit.robot.geometry import from_rotation, to_rotation
from motionkit.trajopt.solve import Solution

CONTACT_FORCE = 1.0  # N: a foot is in contact when its corners carry more than this in total


def to_trajectory(solution: Solution, robot: Robot, metrics: dict[str, Any]) -> Trajectory:
    """The knots resampled to `config.rate`, with the planned force of every sole corner [N,
    world frame]. Joint and base positions follow shape-preserving cubics through the knots
    (PCHIP: no overshoot, so a joint on its limit stays there) and the orientation a rotation
    spline; the velocities written are their derivatives, so that a clip's velocities agree with
    its positions (the plan's own knot velocities, forward-Euler steps that change abruptly from
    knot to knot, are in the .knots.npz). Forces, thrust and throttle are linear, one knot
    interval late: in the plan's explicit Euler steps the forces of knot k move the positions
    from knot k + 1 on (the second difference of the positions about knot k + 1 is the
    acceleration of knot k), so that is where they act on the smooth positions. Contacts follow
    the forces."""
    knots, config = solution.knots, solution.config
    time = solution.time
    frames = int(np.floor(time[-1] * config.rate + 1e-9)) + 1
    out_time = np.arange(frames) / config.rate
    force_time = np.maximum(out_time - float(np.median(np.diff(time))), 0.0)

    def lerp(name: str) -> np.ndarray:
        values = knots[name]
        return np.stack(
            [np.interp(force_time, time, values[:, i]) for i in range(values.shape[1])], 1
        )

    def smooth(name: str) -> tuple[np.ndarray, np.ndarray]:
        curve = PchipInterpolator(time, knots[name], axis=0)
        return curve(out_time), curve.derivative()(out_time)

    joints, joint_velocities = smooth("joints")
    base_position, base_velocity = smooth("base_position")
    spline = RotationSpline(time, to_rotation(knots["base_quaternion"]))
    orientation = spline(out_time)
    omega = orientation.apply(spline(out_time, 1))  # scipy's rate is in the body frame
    per_foot = knots["forces"].shape[1] // 3 // len(robot.spec.feet)
    normal = knots["forces"][:, 2::3].reshape(len(time), len(robot.spec.feet), per_foot)
    loaded = normal.sum(axis=2) > CONTACT_FORCE
    interval = np.clip(np.searchsorted(time, force_time, "right") - 1, 0, len(time) - 1)
    throttle = lerp("throttle") if config.jets.model == "p250" else None
    corners = corner_names(robot)  # the knots' corner order (trajopt.kinematics)
    return Trajectory(
        time=out_time,
        base_position=base_position,
        base_orientation=from_rotation(orientation),
        joint_names=robot.joint_names,
        joint_positions=joints,
        joint_velocities=joint_velocities,
        base_linear_velocity=base_velocity,
        base_angular_velocity=omega,
        thrust=lerp("thrust"),
        throttle=throttle,
        contacts=loaded[interval],
        jet_names=tuple(jet.name for jet in robot.spec.jets),
        foot_names=tuple(foot.side for foot in robot.spec.feet),
        corner_names=corners,
        contact_forces=lerp("forces").reshape(frames, len(corners), 3),
        metadata=Metadata(
            robot=robot.name,
            robot_hash=robot.model_hash,
            kind=config.kind,
            generator="trajopt",
            source=Source(clip=config.scenario.name),
            config=json.loads(json.dumps(config.to_dict())),
            metrics=metrics,
        ),
    )


def knot_trajectory(solution: Solution, robot: Robot) -> Trajectory:
    """The plan at its knots, with its own knot velocities and forces (no resampling)."""
    knots = solution.knots
    count = len(solution.time)
    forces = knots["forces"].reshape(count, -1, 3)
    per_foot = forces.shape[1] // len(robot.spec.feet)
    quaternion = knots["base_quaternion"]
    return Trajectory(
        time=solution.time,
        base_position=knots["base_position"],
        base_orientation=quaternion / np.linalg.norm(quaternion, axis=1, keepdims=True),
        joint_names=robot.joint_names,
        joint_positions=knots["joints"],
        joint_velocities=knots["joint_velocities"],
        base_linear_velocity=knots["base_velocity"],
        base_angular_velocity=knots["base_angular_velocity"],
        thrust=knots["thrust"],
        contacts=forces[..., 2].reshape(count, -1, per_foot).sum(axis=2) > CONTACT_FORCE,
        jet_names=tuple(jet.name for jet in robot.spec.jets),
        foot_names=tuple(foot.side for foot in robot.spec.feet),
        corner_names=corner_names(robot),
        contact_forces=forces,
        metadata=Metadata(robot.name, robot.model_hash, "other", "trajopt"),
    )


def physics_figures(solution: Solution, robot: Robot, clip: Trajectory) -> dict[str, Any]:
    """The physics check of the plan at its knots (`physics`: accelerations and momentum rates
    by forward differences, the plan's explicit Euler steps, so its residual is that of the
    planned forces) and of the resampled clip (`physics_clip`: central differences, forces
    interpolated between knots)."""
    plan = PhysicsConfig(smoothing_hz=0.0, differences="forward")
    return {
        "physics": check_physics(knot_trajectory(solution, robot), robot, plan).summary(),
        "physics_clip": check_physics(clip, robot).summary(),
    }


def write_outputs(
    folder: Path, name: str, solution: Solution, robot: Robot, metrics: dict[str, Any]
) -> Path:
    """`name`.mcap (the clip), `name`.knots.npz (every knot block [SI], dt, time) and
    `name`.config.json (the resolved config and the figures); each written atomically, the clip
    last."""
    write_files(Path(folder), encode_outputs(name, solution, robot, metrics))
    return Path(folder) / f"{name}.mcap"


def encode_outputs(
    name: str, solution: Solution, robot: Robot, metrics: dict[str, Any]
) -> dict[str, bytes]:
    """The files of `write_outputs` as name -> bytes, in the order they are written (the clip
    last: a clip has its companions)."""
    trajectory = to_trajectory(solution, robot, metrics)
    metrics = metrics | physics_figures(solution, robot, trajectory)
    trajectory = replace(trajectory, metadata=replace(trajectory.metadata, metrics=metrics))
    buffer = io.BytesIO()
    np.savez_compressed(buffer, time=solution.time, dt=solution.dt, **solution.knots)
    resolved = {"config": solution.config.to_dict(), "metrics": metrics}
    return {
        f"{name}.knots.npz": buffer.getvalue(),
        f"{name}.config.json": (json.dumps(resolved, indent=2) + "\n").encode(),
        f"{name}.mcap": encode(trajectory, robot),
    }
