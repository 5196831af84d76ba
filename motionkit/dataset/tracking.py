"""Can the simulated robot follow a clip? Open-loop tracking in MuJoCo, window by window.

Each window starts from the clip's own state at that frame; the joints follow the clip by PD
(the spec's gains) plus its inverse-dynamics torques as feed-forward (motionkit.dataset.physics),
within the effort limits, and the jets give the clip's thrust: nothing acts on the base. A
window falls when the base comes down more than `drop` below its height standing in the spec's
posture, or tilts more than `tilt` [rad] from the clip's (a flight that drifts off its plan does
not fall). Without the feed-forward (`feedforward=False`) the PD alone holds the
joints, and sags under load.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from motionkit.core.errors import DatasetError
from motionkit.core.extras import require
from motionkit.dataset.trajectory import Trajectory
from motionkit.robot import Robot
from motionkit.robot.geometry import to_rotation
from motionkit.robot.mjcf import standing_height


@dataclass(frozen=True)
class Tracking:
    windows: int
    falls: int
    starts: tuple[float, ...]  # s, the start time of each window
    fell: tuple[bool, ...]

    @property
    def fall_share(self) -> float:
        return self.falls / self.windows if self.windows else 0.0


def track_windows(
    trajectory: Trajectory,
    robot: Robot,
    window: float = 1.0,
    stride: float = 0.25,
    drop: float = 0.25,
    tilt: float = 0.8,
    feedforward: bool = True,
) -> Tracking:
    """Open-loop tracking of every `window`-second stretch (starts `stride` s apart)."""
    from motionkit.dataset.physics import check_physics

    require("train", "tracking a clip", DatasetError, ("mujoco",))
    import mujoco

    if trajectory.joint_names != robot.joint_names:
        raise DatasetError(f"the clip's joints are not those of {robot.name}")
    model = mujoco.MjModel.from_xml_string(robot.mjcf_text)
    data = mujoco.MjData(model)
    time = trajectory.time
    joints = len(robot.joint_names)
    model.actuator_gainprm[:joints] = 0.0  # the joints' PD is applied below, with the torques
    model.actuator_biasprm[:joints] = 0.0
    gains = np.array([robot.spec.simulation.gains(name) for name in robot.joint_names])
    effort = robot.limits.effort
    torques = (
        check_physics(trajectory, robot).torques if feedforward else np.zeros((len(time), joints))
    )
    rotations = to_rotation(trajectory.base_orientation.astype(float))
    up = rotations.apply([0.0, 0.0, 1.0])
    floor = standing_height(robot, robot.spec.posture_angles()) - drop  # base lower: fallen
    starts = np.arange(time[0], time[-1] - window + 1e-9, stride)
    fell = []
    for start in starts:
        k = int(np.searchsorted(time, start))
        mujoco.mj_resetData(model, data)
        data.qpos[:3] = trajectory.base_position[k]
        data.qpos[3:7] = trajectory.base_orientation[k]
        data.qpos[7 : 7 + joints] = trajectory.joint_positions[k]
        data.qvel[:3] = trajectory.base_linear_velocity[k]
        data.qvel[3:6] = rotations[k].inv().apply(trajectory.base_angular_velocity[k])  # body
        data.qvel[6 : 6 + joints] = trajectory.joint_velocities[k]
        mujoco.mj_forward(model, data)
        fallen = False
        while data.time < window and not fallen:
            now = time[k] + data.time
            target = _at(now, time, trajectory.joint_positions)
            speed = _at(now, time, trajectory.joint_velocities)
            q, qd = data.qpos[7 : 7 + joints], data.qvel[6 : 6 + joints]
            pd = gains[:, 0] * (target - q) + gains[:, 1] * (speed - qd)
            data.qfrc_applied[6 : 6 + joints] = np.clip(
                pd + _at(now, time, torques), -effort, effort
            )
            data.ctrl[joints:] = [
                np.interp(now, time, trajectory.thrust[:, i])
                for i in range(trajectory.thrust.shape[1])
            ]
            mujoco.mj_step(model, data)
            frame = min(int(np.searchsorted(time, now)), len(time) - 1)
            body_up = data.xmat[1].reshape(3, 3)[:, 2]
            fallen = bool(
                data.qpos[2] < floor or np.arccos(np.clip(body_up @ up[frame], -1, 1)) > tilt
            )
        fell.append(fallen)
    return Tracking(len(fell), int(sum(fell)), tuple(map(float, starts)), tuple(fell))


def _at(now: float, time: np.ndarray, values: np.ndarray) -> np.ndarray:
    """Rows of `values` linearly interpolated at time `now`."""
    k = int(np.clip(np.searchsorted(time, now) - 1, 0, len(time) - 2))
    blend = float(np.clip((now - time[k]) / (time[k + 1] - time[k]), 0.0, 1.0))
    return (1 - blend) * values[k] + blend * values[k + 1]
