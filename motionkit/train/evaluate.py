"""Evaluation: deterministic rollouts of the policy from standing starts, their figures (task,
gait, flight), and the first episode of environment 0 as a motion clip (MCAP) for the viewer."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

from motionkit.dataset import Metadata, Source, Trajectory, write
from motionkit.robot import Robot
from motionkit.robot.geometry import angular_velocity
from motionkit.train.learner import Learner, Trainer

FIELDS = (
    "done",
    "truncated",
    "hit",
    "timed_out",
    "hit_steps",
    "approach_speed",
    "airborne",
    "feet_down",
    "switches",
    "task_reward",
)  # of StepInfo
FIRST_ONLY = ("qpos", "target")  # kept for environment 0 alone: its clip is saved


def evaluate(
    trainer: Trainer, learner: Learner, key: jax.Array, chunks: int
) -> tuple[dict[str, float], dict[str, np.ndarray]]:
    """`chunks` rollouts of rollout_steps without action noise from standing starts (episodes
    that end restart standing). Figures per episode count the episodes still running at the
    end as (partial) episodes."""
    k_reset, k_run = jax.random.split(key)
    state = trainer.reset_standing(jax.random.split(k_reset, trainer.config.ppo.num_envs))
    parts: dict[str, list[np.ndarray]] = {name: [] for name in (*FIELDS, "thrust", *FIRST_ONLY)}
    for k in jax.random.split(k_run, chunks):
        state, batch = trainer.rollout(learner, state, k, jnp.array(0.0))
        for name in FIELDS:
            parts[name].append(np.asarray(getattr(batch.info, name)))
        parts["thrust"].append(np.asarray(batch.thrust))
        for name in FIRST_ONLY:
            parts[name].append(np.asarray(getattr(batch, name)[:, :1]))
    arrays = {name: np.concatenate(value) for name, value in parts.items()}
    done, truncated = arrays["done"], arrays["truncated"]
    steps, envs = done.shape
    ended = int(done.sum())
    episodes = ended + envs
    control_hz = trainer.config.env.control_hz
    lengths = _episode_lengths(done)
    hits = int(arrays["hit"].sum())
    feet_down = arrays["feet_down"]
    metrics = {
        "eval_waypoints_per_episode": float(hits / episodes),
        "eval_approach_speed": float(arrays["approach_speed"].mean()),
        "eval_single_support_share": float((feet_down.sum(-1) == 1).mean()),
        "eval_contact_switches_per_second": float(arrays["switches"].mean() * control_hz),
        "eval_seconds_to_waypoint": float(arrays["hit_steps"].sum() / hits / control_hz)
        if hits
        else float("nan"),
        "eval_waypoints_missed": float(arrays["timed_out"].sum() / episodes),
        "eval_airborne_share": float(arrays["airborne"].mean()),
        "eval_ground_share": float(1.0 - arrays["airborne"].mean()),
        "eval_thrust_usage": float((arrays["thrust"] / np.asarray(trainer.env.t_max)).mean()),
        "eval_falls_per_episode": float((done & ~truncated).sum() / episodes),
        "eval_episode_seconds": float(np.mean(lengths) / control_hz)
        if lengths
        else steps / control_hz,
        "eval_task_reward": float(arrays["task_reward"].mean()),
        "eval_episodes": float(episodes),
    }
    return metrics, arrays


def _episode_lengths(done: np.ndarray) -> list[int]:
    """Lengths of the episodes that ended, for every environment (time-major done)."""
    lengths = []
    for column in done.T:
        ends = np.flatnonzero(column)
        lengths += np.diff(np.concatenate([[-1], ends])).tolist()
    return lengths


def first_episode(
    arrays: dict[str, np.ndarray], robot: Robot, control_hz: float, config: dict[str, Any]
) -> Trajectory | None:
    """The first episode of environment 0 as a clip (None if it lasted less than 2 steps);
    the waypoints it pursued go into the metadata config as [time, x, y, z] rows. Its
    velocities are those its positions imply (central differences at the control rate): the
    simulator's, sampled once per control step, move within the step and disagree with them."""
    done = arrays["done"][:, 0]
    end = int(np.argmax(done)) if done.any() else len(done)
    if end < 2:
        return None
    qpos = arrays["qpos"][:end, 0].astype(float)
    time = np.arange(1, end + 1) / control_hz
    orientation = qpos[:, 3:7] / np.linalg.norm(qpos[:, 3:7], axis=1, keepdims=True)
    targets = arrays["target"][:end, 0]
    change = np.concatenate([[True], np.any(np.diff(targets, axis=0) != 0, axis=1)])
    route = [
        [round(float(t - 1 / control_hz), 4), *map(float, p)]
        for t, p in zip(time[change], targets[change], strict=True)
    ]
    spec = robot.spec
    return Trajectory(
        time=time,
        base_position=qpos[:, :3],
        base_orientation=orientation,
        joint_names=robot.joint_names,
        joint_positions=qpos[:, 7:],
        joint_velocities=np.gradient(qpos[:, 7:], time, axis=0),
        base_linear_velocity=np.gradient(qpos[:, :3], time, axis=0),
        base_angular_velocity=angular_velocity(time, orientation),
        thrust=arrays["thrust"][:end, 0],
        contacts=arrays["feet_down"][:end, 0],
        jet_names=tuple(jet.name for jet in spec.jets),
        foot_names=tuple(foot.side for foot in spec.feet),
        metadata=Metadata(
            robot=robot.name,
            robot_hash=robot.model_hash,
            kind="rollout",
            generator="rollout",
            source=Source(clip=str(config.get("clip", "evaluation"))),
            config={**config, "waypoints": route},
        ),
    )


def save_rollout(
    path: Path,
    arrays: dict[str, np.ndarray],
    robot: Robot,
    control_hz: float,
    config: dict[str, Any],
) -> Path | None:
    """Write the first episode of environment 0 as MCAP; None when it was too short."""
    trajectory = first_episode(arrays, robot, control_hz, config)
    return None if trajectory is None else write(path, trajectory, robot)
