"""Replay of a solution in MuJoCo: joints tracked by the MJCF's PD position actuators, thrust
applied open loop by the jet motors, base position compared with the plan.

The plan's explicit-Euler dynamics hold each knot's forces over its interval, so the replay holds
each knot's thrust too (linear interpolation of thrust drifts by half an interval's impulse per
knot). Open loop, a flying robot drifts anyway: the error grows over the motion.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from motionkit.errors import TrajoptError
from motionkit.robot import Robot
from motionkit.trajopt.solve import Solution


def replay(solution: Solution, robot: Robot) -> dict[str, Any]:
    """Simulate the plan; return the base position error against it (max, final, RMS) [m]."""
    try:
        import mujoco
    except ImportError as exc:
        raise TrajoptError("the replay check needs MuJoCo: pip install mujoco") from exc
    knots = solution.knots
    model = mujoco.MjModel.from_xml_string(robot.mjcf_text)
    data = mujoco.MjData(model)
    quat = knots["base_quaternion"] / np.linalg.norm(knots["base_quaternion"], axis=1)[:, None]
    data.qpos[:3] = knots["base_position"][0]
    data.qpos[3:7] = quat[0]
    data.qpos[7:] = knots["joints"][0]
    rotation = np.empty(9)
    mujoco.mju_quat2Mat(rotation, quat[0])
    data.qvel[:3] = knots["base_velocity"][0]
    data.qvel[3:6] = rotation.reshape(3, 3).T @ knots["base_angular_velocity"][0]  # body frame
    data.qvel[6:] = knots["joint_velocities"][0]
    mujoco.mj_forward(model, data)

    times = solution.time
    joints = len(robot.joint_names)
    errors = []
    step = model.opt.timestep
    for k in range(len(times)):
        errors.append(np.linalg.norm(data.qpos[:3] - knots["base_position"][k]))
        if k == len(times) - 1:
            break
        substeps = max(1, round(solution.dt / step))
        for i in range(substeps):
            blend = i / substeps
            target = (1 - blend) * knots["joints"][k] + blend * knots["joints"][k + 1]
            data.ctrl[:joints] = target
            data.ctrl[joints:] = knots["thrust"][k]  # held over the interval, as in the plan
            mujoco.mj_step(model, data)
    errors_array = np.array(errors)
    return {
        "replay_base_error_max_m": float(errors_array.max()),
        "replay_base_error_final_m": float(errors_array[-1]),
        "replay_base_error_rms_m": float(np.sqrt(np.mean(errors_array**2))),
        "replay_base_error_per_knot_m": [round(float(e), 5) for e in errors_array],
    }
