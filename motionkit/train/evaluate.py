"""Evaluation: deterministic rollouts of the policy from standing starts (or, to find out what a
policy does elsewhere, from prior frames and with action noise), their figures (task, gait,
flight, and the take-off and landing times of `figures.transition_figures`), and the first
episode of environment 0 as a motion clip (MCAP) for the viewer, with the commanded throttle
of fitted jets; on a course, the clip records its terrain (`courses.clip_terrain`) for the
viewer to draw."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

from motionkit.dataset import Metadata, Source, Trajectory, write
from motionkit.robot import Robot
from motionkit.robot.geometry import angular_velocity
from motionkit.train.env import Env
from motionkit.train.env.courses import CourseLayout, clip_terrain
from motionkit.train.env.rewards import style_reward
from motionkit.train.figures import rollout_figures, transition_figures
from motionkit.train.learner import Learner, Rollout, Trainer

KEPT = ("qpos", "target")  # kept for environment 0 alone: its clip is saved
TERRAIN_MARGIN = 1.5  # m of a course's grid a clip records about its path and waypoints
# besides every StepInfo field but these (observations and features: large, and unused here)
DROPPED = ("final_obs", "chi_next")


def evaluate(
    trainer: Trainer,
    learner: Learner,
    key: jax.Array,
    chunks: int,
    prior_share: float = 0.0,
    noise: float = 0.0,
    tile: tuple[int, int] | None = None,
) -> tuple[dict[str, float], dict[str, np.ndarray]]:
    """`chunks` rollouts of rollout_steps, their figures (`rollout_figures` and
    `transition_figures`, prefixed "eval_") and the arrays: every StepInfo field but DROPPED,
    the thrust, the jets' mean command ("command", `Jets.command_share`), and KEPT (with
    fitted jets also the throttle [%]) for environment 0.
    A run with priors adds the discriminator's view of the rollout's transitions: its accuracy
    on them (the share it tells from the priors') and their mean style reward.

    Args:
        prior_share: the share of the starts in prior frames (0: all standing, the
            evaluation's own), kept when an ended episode starts again.
        noise: the action noise in units of the policy's std (0: deterministic).
        tile: on a course, the tile (kind index, level) every robot starts on (None: each a
            random tile of the course); the tiles hold still.
    """
    k_reset, k_run = jax.random.split(key)
    keys = jax.random.split(k_reset, trainer.config.ppo.num_envs)
    state = trainer.reset_evaluation(keys, prior_share, tile)
    infos, records, logits = [], [], []
    for k in jax.random.split(k_run, chunks):
        state, batch = trainer.rollout(learner, state, k, jnp.array(noise))
        if trainer.config.priors:
            chi, chi_next = learner.amp_norm(batch.chi), learner.amp_norm(batch.info.chi_next)
            logits.append(np.asarray(trainer.style.net.apply(learner.disc, chi, chi_next)))
        empty = {name: np.zeros((*batch.info.done.shape, 0)) for name in DROPPED}
        infos.append(jax.tree.map(np.asarray, batch.info.replace(**empty)))
        records.append(_records(trainer.env, batch))
    info = jax.tree.map(lambda *x: np.concatenate(x), *infos)
    arrays = {name: np.asarray(getattr(info, name)) for name in info.__dataclass_fields__}
    arrays |= {name: np.concatenate([r[name] for r in records]) for name in records[0]}
    env, hz = trainer.env, trainer.config.env.control_hz
    figures = rollout_figures(info, arrays["thrust"], env.t_max, hz, env.kinds, levels=False)
    air_level = 0.5 * (env.config.ground_height + env.config.air_height[0])  # waypoints.in_air
    figures |= transition_figures(arrays, arrays["command"], air_level, hz)
    metrics = {f"eval_{name}": float(value) for name, value in figures.items()}
    if logits:
        scale = trainer.config.amp.style_scale
        metrics["eval_disc_policy_accuracy"] = float(np.mean(np.concatenate(logits) < 0))
        metrics["eval_style_reward"] = float(jnp.mean(style_reward(jnp.array(logits), scale)))
    return metrics | {"eval_ground_share": 1.0 - metrics["eval_airborne_share"]}, arrays


def _records(env: Env, batch: Rollout) -> dict[str, np.ndarray]:
    """The thrust, the jets' mean command (share of its range above rest) and KEPT of one
    rollout, with the throttle [%] of environment 0 for fitted jets."""
    jets = env.jets
    actions = np.asarray(batch.actions[..., env.num_joints :])
    thrust = np.asarray(batch.thrust)
    out = {"thrust": thrust, "command": np.asarray(jets.command_share(actions, thrust)).mean(-1)}
    out |= {name: np.asarray(getattr(batch, name)[:, :1]) for name in KEPT}
    if jets.fitted:
        out["throttle"] = np.asarray(jets.throttle(np.clip(actions[:, :1], -1.0, 1.0)))
    return out


def first_episode(
    arrays: dict[str, np.ndarray],
    robot: Robot,
    control_hz: float,
    config: dict[str, Any],
    course: CourseLayout | None = None,
) -> Trajectory | None:
    """The first episode of environment 0 as a clip (None if it lasted less than 2 steps);
    the waypoints it pursued go into the metadata config as [time, x, y, z] rows, and on a
    `course` (arrays "level" and "kind" of its tile) its terrain (`courses.clip_terrain`,
    TERRAIN_MARGIN about its path and waypoints) as "terrain". Its velocities are those its
    positions imply (central differences at the control rate): the simulator's, sampled once
    per control step, move within the step and disagree with them."""
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
    extra: dict[str, Any] = {"waypoints": route}
    if course is not None:
        xy = np.concatenate([qpos[:, :2], targets[:, :2]])
        level, kind = int(arrays["level"][0, 0]), int(arrays["kind"][0, 0])
        low, high = xy.min(0) - TERRAIN_MARGIN, xy.max(0) + TERRAIN_MARGIN
        extra["terrain"] = clip_terrain(course, level, kind, low, high)
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
        throttle=arrays["throttle"][:end, 0] if "throttle" in arrays else None,
        contacts=arrays["feet_down"][:end, 0],
        jet_names=tuple(jet.name for jet in spec.jets),
        foot_names=tuple(foot.side for foot in spec.feet),
        metadata=Metadata(
            robot=robot.name,
            robot_hash=robot.model_hash,
            kind="rollout",
            generator="rollout",
            source=Source(clip=str(config.get("clip", "evaluation"))),
            config={**config, **extra},
        ),
    )


def save_rollout(
    path: Path,
    arrays: dict[str, np.ndarray],
    robot: Robot,
    control_hz: float,
    config: dict[str, Any],
    course: CourseLayout | None = None,
) -> Path | None:
    """Write the first episode of environment 0 as MCAP (on a `course`, with its terrain);
    None when it was too short."""
    trajectory = first_episode(arrays, robot, control_hz, config, course)
    return None if trajectory is None else write(path, trajectory, robot)
