"""Motion priors for the discriminator and for resets: the [priors.NAME] clips of a config as
AMP transition pairs at the control rate, each prior weighted by its `weight`, with the state
every transition starts from (so that an episode can start there)."""

from __future__ import annotations

import numpy as np

from motionkit.core.errors import DatasetError, TrainError
from motionkit.dataset import MotionDataset
from motionkit.dataset.amp import amp_pairs, resample
from motionkit.dataset.collection import find_clips
from motionkit.dataset.trajectory import Trajectory
from motionkit.dataset.validate import read_valid
from motionkit.robot import Robot
from motionkit.robot.geometry import quat_rotate_inverse, to_rotation
from motionkit.robot.kinematics import frame_poses
from motionkit.robot.mirror import Mirror, mirror_trajectory
from motionkit.train.amp import PriorData, PriorStates
from motionkit.train.config import PriorConfig
from motionkit.train.env.task import AIRBORNE_CLEARANCE


def load_priors(
    priors: dict[str, PriorConfig], robot: Robot, rate: float, mirror: Mirror | None = None
) -> tuple[PriorData | None, dict[str, dict[str, float]]]:
    """The combined dataset transitions (None without priors) and a summary per prior. Every
    clip is checked first as `dataset validate` checks it (another model of the robot with the
    same names passes): a TrainError names the prior, the file and what is wrong. With a
    `mirror`, each clip is used twice, as it is and mirrored (its weight shared between them)."""
    if not priors:
        return None, {}
    currents, followings, probabilities, states, summary = [], [], [], [], {}
    total_weight = sum(p.weight for p in priors.values())
    for name, prior in priors.items():
        try:
            for path in find_clips(list(prior.paths)):  # as `dataset validate` checks them
                read_valid(path, robot, other_model=True)
            dataset = MotionDataset(list(prior.paths))
            pairs = dataset.amp_pairs(robot, rate)  # (checks the clips' robot)
            trajectories = [t for _, t in dataset.trajectories()]
            if mirror is not None:
                weights = [clip.weight for clip in dataset.clips] * 2
                trajectories += [mirror_trajectory(t, mirror) for t in trajectories]
                pairs = amp_pairs(trajectories, robot, rate, weights)
            clips = [resample(t, rate) for t in trajectories]
            heights = [sole_heights(clip, robot) for clip in clips]
            frames = [prior_states(c, robot, h) for c, h in zip(clips, heights, strict=True)]
            gait = gait_figures(heights, rate)
        except DatasetError as exc:
            raise TrainError(f"prior '{name}': {exc}") from exc
        currents.append(pairs.current)
        followings.append(pairs.following)
        probabilities.append(pairs.probability * prior.weight / total_weight)
        states += frames
        airborne = np.concatenate([f.airborne for f in frames])
        summary[name] = {
            "clips": len(dataset),
            "seconds": round(dataset.duration, 3),
            "pairs": len(pairs.current),
            "weight": prior.weight,
            "airborne_share": round(float(airborne.mean()), 4),
        } | {key: round(value, 4) for key, value in gait.items()}
    combined = PriorStates(
        *(np.concatenate([getattr(s, f) for s in states]) for f in PriorStates.__dataclass_fields__)
    )
    data = PriorData.create(
        np.concatenate(currents),
        np.concatenate(followings),
        np.concatenate(probabilities),
        combined,
    )
    return data, summary


def prior_states(clip: Trajectory, robot: Robot, heights: np.ndarray) -> PriorStates:
    """The MuJoCo state of every frame of the clip (at the control rate) but the last (the
    frames that start a transition): qpos, qvel (angular velocity in the base frame), thrust,
    airborne (from the clip's `sole_heights`)."""
    if tuple(clip.joint_names) != tuple(robot.joint_names):
        raise DatasetError(
            f"clip joints {list(clip.joint_names)} are not the robot's {list(robot.joint_names)}"
        )
    quats = clip.base_orientation.astype(float)
    angular = quat_rotate_inverse(quats, clip.base_angular_velocity.astype(float))
    qpos = np.concatenate([clip.base_position, quats, clip.joint_positions], axis=1)
    qvel = np.concatenate([clip.base_linear_velocity, angular, clip.joint_velocities], axis=1)
    airborne = np.all(heights > AIRBORNE_CLEARANCE, axis=1)
    return PriorStates(
        qpos=qpos[:-1].astype(np.float32),
        qvel=qvel[:-1].astype(np.float32),
        thrust=np.asarray(clip.thrust[:-1], np.float32),
        airborne=airborne[:-1],
    )


def sole_heights(clip: Trajectory, robot: Robot) -> np.ndarray:
    """(frames, feet) each sole's height above the ground plane z = 0 [m]."""
    soles = [foot.sole for foot in robot.spec.feet]
    poses = frame_poses(robot.model, clip.joint_names, clip.joint_positions, soles)
    rotation = to_rotation(clip.base_orientation.astype(float))
    local = [rotation.apply(poses[:, i, :3, 3])[:, 2] for i in range(len(soles))]
    return np.stack(local, axis=1) + clip.base_position[:, 2:3]


def gait_figures(heights: list[np.ndarray], rate: float) -> dict[str, float]:
    """The gait figures of the training's evaluation for clips' sole heights (each (frames,
    feet), at `rate` Hz; a foot is down within AIRBORNE_CLEARANCE): the share of frames on one
    foot, touch-downs plus lift-offs per foot per second, and the highest sole [m]."""
    down = [h <= AIRBORNE_CLEARANCE for h in heights]
    frames = sum(len(d) for d in down)
    single = sum(int((d.sum(axis=1) == 1).sum()) for d in down)
    switches = sum(int((d[1:] != d[:-1]).sum()) for d in down)
    foot_steps = sum(d[1:].size for d in down)
    return {
        "single_support_share": single / frames,
        "contact_switches_per_second": switches / foot_steps * rate if foot_steps else 0.0,
        "sole_clearance_max_m": float(max(h.max() for h in heights)),
    }
