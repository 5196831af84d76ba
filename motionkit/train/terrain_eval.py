"""A terrain policy evaluated per tile: every kind x level of a course that training did not use
(`courses.held_out`), `robots` robots per row, one episode each from standing on the tile's pad,
deterministic, the tiles held still.

    rows = evaluate_tiles(Path("runs/terrain"), robot)       # 512 robots per kind x level
    print(tile_table(rows))

Per row, over each robot's first episode: waypoints reached, the share of successes (the
route's `route_waypoints` waypoints reached in turn, none missed, no fall), falls, the airborne
share on the way and over holes (pits, gaps between stones), the jets' impulse per metre the base
moved (N s / m) and the speed toward the waypoint (m/s).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, replace
from pathlib import Path

import jax
import numpy as np

from motionkit.core.errors import TrainError
from motionkit.robot import Robot
from motionkit.runtime.progress import Progress, silent
from motionkit.train.checkpoint import NAME, load_checkpoint
from motionkit.train.config import TrainConfig

ROBOTS = 512  # per row
FIGURES = ("waypoints_per_episode", "success_share", "falls_per_episode", "airborne_share",
           "airborne_share_over_hole", "thrust_per_metre", "speed")  # fmt: skip


@dataclass(frozen=True)
class TileRow:
    """The figures of one tile (kind, level)."""

    kind: str
    level: int
    robots: int
    waypoints_per_episode: float
    success_share: float
    falls_per_episode: float
    airborne_share: float
    airborne_share_over_hole: float  # NaN where no robot was over a hole
    thrust_per_metre: float  # N s / m
    speed: float  # m/s toward the waypoint


def first_episode_figures(arrays: dict[str, np.ndarray], control_hz: float) -> dict[str, float]:
    """The figures of each robot's first episode in time-major (T, N, ...) evaluation arrays
    (`evaluate.evaluate`'s: StepInfo fields and "thrust"): the steps up to its first end (all,
    for a robot whose episode did not end); the thrust of the ending step is the next
    episode's and is left out."""
    done = arrays["done"]
    steps, robots = done.shape
    ended = done.any(axis=0)
    last = np.where(ended, np.argmax(done, axis=0), steps - 1)
    t = np.arange(steps)[:, None]
    within = t <= last
    pushed = within & ~(ended & (t == last))  # the thrust of the episode's own steps
    columns = np.arange(robots)
    fell = ended & ~arrays["truncated"][last, columns]
    success = arrays["route_done"][last, columns] & ~fell
    airborne, hole = arrays["airborne"] & within, arrays["over_hole"] & within
    impulse = (arrays["thrust"].sum(-1) * pushed).sum() / control_hz
    moved = (arrays["moved"] * within).sum()
    return {
        "waypoints_per_episode": float((arrays["hit"] & within).sum() / robots),
        "success_share": float(success.mean()),
        "falls_per_episode": float(fell.mean()),
        "airborne_share": float(airborne.sum() / within.sum()),
        "airborne_share_over_hole": float((airborne & hole).sum() / hole.sum())
        if hole.any()
        else math.nan,
        "thrust_per_metre": float(impulse / max(moved, 1e-6)),
        "speed": float(arrays["approach_speed"][within].mean()),
    }


def tile_config(config: TrainConfig, robots: int, course: int) -> TrainConfig:
    """`config` for `robots` environments (one device; the update is never run) on the
    held-out course `course`."""
    from motionkit.train.env.courses import CourseLayout, held_out

    seed = held_out(CourseLayout.of(config.env), course).seed
    steps = config.ppo.rollout_steps
    ppo = replace(config.ppo, num_envs=robots, minibatch_size=robots * steps)
    return replace(
        config,
        env=replace(config.env, terrain_seed=seed),
        ppo=ppo,
        run=replace(config.run, devices=1),
    )


def evaluate_tiles(
    run: Path,
    robot: Robot,
    *,
    robots: int = ROBOTS,
    course: int = 0,
    checkpoint: Path | None = None,
    stage: str | None = None,
    progress: Progress = silent,
) -> list[TileRow]:
    """A terrain run's policy on every kind x level of the held-out course `course`.

    Args:
        run: the OUT of `train` (config.toml, checkpoint.msgpack) of the terrain scenario.
        robot: the robot it was trained for.
        robots: robots per row, each one episode from standing on the tile's pad.
        course: the held-out course (seed courses.HELD_OUT + course).
        checkpoint: another checkpoint of the run instead of its latest.
        stage: with a curriculum, evaluate in this stage's config (default: the checkpoint's).
        progress: receives a line per row.

    Returns:
        One row per kind and level, kinds in the config's order, levels from 0 up.

    Raises:
        TrainError: a run that is not one of the terrain scenario, no checkpoint, or fewer
            than one robot.
    """
    from motionkit.train.evaluate import evaluate
    from motionkit.train.runner import _evaluated_stage, build_trainer

    run = Path(run)
    if robots < 1:
        raise TrainError(f"--robots {robots}: at least 1")
    if not (run / "config.toml").is_file():
        raise TrainError(f"{run}: no config.toml (not the OUT of motionkit train?)")
    checkpoint = run / NAME if checkpoint is None else Path(checkpoint)
    if not checkpoint.is_file():
        raise TrainError(f"{checkpoint}: no such checkpoint")
    config = _evaluated_stage(run, TrainConfig.from_toml(run / "config.toml"), stage)
    if config.env.scenario != "terrain":
        raise TrainError(f"{run}: a run on {config.env.scenario} ground has no tiles to evaluate")
    config, trainer, _ = build_trainer(tile_config(config, robots, course), robot, False)
    template, _ = trainer.init(config.run.seed)
    learner = trainer.replicate(load_checkpoint(checkpoint, template)[0])
    env = config.env
    chunks = math.ceil((env.max_steps + 1) / config.ppo.rollout_steps)
    rows = []
    for kind, name in enumerate(trainer.env.kinds):
        for level in range(env.terrain_levels):
            key = jax.random.fold_in(jax.random.key(course), kind * 1000 + level)
            _, arrays = evaluate(trainer, learner, key, chunks, tile=(kind, level))
            figures = first_episode_figures(arrays, env.control_hz)
            rows.append(TileRow(name, level, robots, **figures))
            progress(tile_table(rows[-1:], header=not rows[:-1]))
    return rows


def tile_table(rows: list[TileRow], header: bool = True) -> str:
    """Rows as a Markdown table (with its header, or its lines alone)."""
    names = ("kind", "level", "waypoints", "success", "falls", "airborne", "airborne over hole",
             "thrust N s/m", "speed m/s")  # fmt: skip
    lines = []
    if header:
        lines = ["| " + " | ".join(names) + " |", "|" + "---|" * len(names)]
    for row in rows:
        values = asdict(row)
        cells = [row.kind, str(row.level)] + [f"{values[name]:.3g}" for name in FIGURES]
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)
