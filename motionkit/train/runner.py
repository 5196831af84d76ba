"""A training run in a folder: config, metrics logs, checkpoints, evaluations and rollouts.

OUT/config.toml             the resolved config (and the priors used)
OUT/train.csv, eval.csv     metrics per iteration / per evaluation (+ OUT/tensorboard/)
OUT/checkpoint.msgpack      the latest learner (resume with resume=True)
OUT/evaluated/iter_N.msgpack  with [run] keep_evaluated: a slim checkpoint of every evaluation
OUT/rollouts/iter_N.mcap    the first evaluation episode of environment 0, for the viewer
OUT/summary.json            priors, last training and evaluation figures, timings
OUT/curves.png              the training curves (redrawn at every evaluation)
OUT/curriculum.json         with a [curriculum]: the stage the checkpoint is in, and its switches
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path
from typing import Any

import jax

from motionkit.core.errors import RobotModelError, TrainError
from motionkit.files.outputs import check_out, claim_out, write_json_atomic, write_text_atomic
from motionkit.robot import Robot
from motionkit.robot.mirror import robot_mirror
from motionkit.runtime.progress import Progress, silent
from motionkit.train import curriculum
from motionkit.train.amp import PriorData
from motionkit.train.checkpoint import NAME, load_checkpoint, save_checkpoint, save_slim
from motionkit.train.config import RunConfig, TrainConfig
from motionkit.train.curves import draw_curves
from motionkit.train.devices import resolve_devices, resolve_impl
from motionkit.train.env import Env
from motionkit.train.evaluate import evaluate, save_rollout
from motionkit.train.learner import Carry, Learner, Trainer
from motionkit.train.metrics_log import MetricsLog
from motionkit.train.policy import Policy
from motionkit.train.priors import load_priors
from motionkit.train.warm_start import init_from_policy

PHYSICS = {
    "jax": "MJX (JAX)",
    "warp": "MJX (MuJoCo Warp)",
    "mujoco": "MuJoCo C (mujoco.batch)",
}
# what a run writes in its folder (see the module doc)
OUTPUTS = (
    "config.toml", "train.csv", "eval.csv", "tensorboard", NAME, "rollouts", "summary.json",
    "curves.png", "evaluated", curriculum.FILE,
)  # fmt: skip


def envs_split(config: TrainConfig) -> int:
    """The devices a config's environments are split over (TrainError if it cannot be)."""
    return resolve_devices(config.run.devices, jax.local_device_count(), config.ppo.num_envs)


def make_env(config: TrainConfig, robot: Robot, prior: PriorData | None = None) -> Env:
    """The environment of a config (with its LSTM jets loaded) and the priors it resets from.

    It is sized for the environments of one device: `ppo.num_envs` divided by the devices
    they are split over.

    Args:
        config: the training config ([env], [reward], [ppo] num_envs, [run] devices).
        robot: the robot to simulate.
        prior: the dataset transitions and states episodes reset from (None: none).

    Returns:
        The environment.

    Raises:
        TrainError: a jet model that cannot be loaded, environments that cannot be split
            over the devices, or priors made for another robot layout.
    """
    jet_model = None
    if config.env.jet != "ideal":
        from motionkit.core.errors import JetIdentError
        from motionkit.jet_ident.export import load_jet

        try:
            jet_model = load_jet(Path(config.env.jet_model), config.env.jet)
        except JetIdentError as exc:
            raise TrainError(f"[env] jet_model: {exc}") from exc
    worlds = config.ppo.num_envs // envs_split(config)
    try:
        return Env(robot, config.env, config.reward, jet_model, prior, worlds)
    except ValueError as exc:  # priors made for another robot layout
        raise TrainError(str(exc)) from exc


def train(
    config: TrainConfig,
    out: Path,
    robot: Robot,
    *,
    resume: bool = False,
    jets_at_rest: bool = False,
    init_from: Policy | None = None,
    progress: Progress = silent,
    stop: Callable[[dict[str, float]], bool] | None = None,
) -> dict[str, Any]:
    """Train (or resume) in `out`; returns the summary also written to OUT/summary.json.

    A run stopped by `max_minutes` (counted from the call, setup and compilation included) is
    evaluated before it returns, like one that completes its iterations. The folder's files
    are listed in the module doc. A config with a [curriculum] trains each stage's config in
    turn (`motionkit.train.curriculum`), switching at evaluations; a resumed run goes on in
    the stage its checkpoint was saved in.

    Args:
        config: the training config; its [priors] tables name the motion priors.
        out: the run's folder (OUT).
        robot: the robot to train.
        resume: continue the run in `out` from its checkpoint; False needs a folder without
            one.
        jets_at_rest: on resuming (or with `init_from`), set the policy's jet outputs to the
            rest action (for a policy trained with another jet action,
            `Trainer.jets_at_rest`).
        init_from: a new run starts with this policy's actor and observation normaliser
            (`motionkit.train.warm_start`; a flat-ground policy widened to a terrain's height
            map); not with `resume`.
        progress: called with each line of progress.
        stop: called with each evaluation's figures; True ends the run early.

    Returns:
        The summary: priors, iterations, env_steps, seconds, the last iteration's training
        figures ("train") and the last evaluation's ("eval").

    Raises:
        TrainError: `resume` without a checkpoint in `out`, a checkpoint there without
            `resume`, an `out` that holds files motionkit did not write, or a config, jet
            model or prior clips the robot cannot train with.
    """
    if resume and init_from is not None:
        raise TrainError("a resumed run goes on from its checkpoint: init_from is for new runs")
    session = _Session(config, Path(out), robot, progress)
    session.open(resume, jets_at_rest, init_from)
    session.loop(stop)
    return session.close()


class _Session:
    """One call of `train`: the trainer of the current stage, the learner and the logs."""

    def __init__(self, config: TrainConfig, out: Path, robot: Robot, progress: Progress) -> None:
        self.start = time.perf_counter()
        self.recipe, self.out, self.robot, self.progress = config, out, robot, progress
        self.last: dict[str, float] = {}
        self.evaluation: dict[str, float] = {}
        self.evaluated_at = -1
        self.window: list[dict[str, float]] = []  # training figures since the last evaluation

    def open(self, resume: bool, jets_at_rest: bool, init_from: Policy | None = None) -> None:
        """Check the folder, build the trainer of the run's stage and its learner (restored
        when resuming); nothing is written before the checks pass."""
        out, checkpoint = self.out, self.out / NAME
        if resume and not checkpoint.exists():
            raise TrainError(f"{out}: nothing to resume (no {NAME})")
        if not resume and checkpoint.exists():
            raise TrainError(f"{out} holds a run already: pass --resume or another --out")
        check_out(out, OUTPUTS, TrainError)
        saved = curriculum.read_state(out, self.recipe) if resume else None
        self.stage = saved or curriculum.CurriculumState()
        config, self.trainer, self.priors = build_trainer(self.stage_config(), self.robot)
        self.learner, self.carry = self.trainer.init(config.run.seed)
        if init_from is not None:
            self._init_from(init_from, jets_at_rest)
        slim = False
        if resume:  # checked before anything is written
            restored, slim = load_checkpoint(checkpoint, self.learner)
            if jets_at_rest:
                restored = self.trainer.jets_at_rest(restored)
            self.learner = self.trainer.replicate(restored)
            self.carry = self._new_carry()
            if saved is None:
                self.stage = curriculum.CurriculumState(since=self.iteration)
        claim_out(out, OUTPUTS, TrainError)
        write_text_atomic(out / "config.toml", self.recipe.to_toml())
        if resume:
            moments = " (a slim checkpoint: the optimisers' moments start afresh)" if slim else ""
            self.progress(f"resumed {out} at iteration {self.iteration}{moments}")
            if jets_at_rest:
                action = config.env.jet_action
                self.progress(f"the policy's jet outputs start at rest ({action} action)")
        self.log = MetricsLog(out, config.run.tensorboard)
        if self.log.note:
            self.progress(self.log.note)
        self._report_setup()

    def _init_from(self, policy: Policy, jets_at_rest: bool) -> None:
        """The fresh learner with `policy`'s actor (checked before anything is written)."""
        env = self.trainer.env
        learner = init_from_policy(jax.device_get(self.learner), policy, env.obs_size, env.chi_size)
        if jets_at_rest:
            learner = self.trainer.jets_at_rest(learner)
        self.learner = self.trainer.replicate(learner)
        widened = " (widened to the height map)" if policy.obs_size != env.obs_size else ""
        self.progress(f"the actor starts from {policy.source}{widened}")

    @property
    def iteration(self) -> int:
        return int(self.learner.iteration)

    def stage_config(self) -> TrainConfig:
        return curriculum.stage_config(self.recipe, self.stage)

    def _new_carry(self) -> Carry:
        """Fresh environments, and the replay buffer kept where it fits the trainer."""
        seed = self.trainer.config.run.seed
        key = jax.random.fold_in(jax.random.key(seed), self.iteration)
        carry = self.trainer.new_carry(*jax.random.split(key))
        old = getattr(self, "carry", None)
        if old is not None and old.buffer.current.shape == carry.buffer.current.shape:
            carry = carry.replace(buffer=old.buffer)
        return carry

    def _report_setup(self) -> None:
        config, env = self.trainer.config, self.trainer.env
        platform = self.trainer.mesh.devices.flat[0].platform
        self.progress(
            f"{config.ppo.num_envs} envs x {config.ppo.rollout_steps} steps per iteration on "
            f"{self.trainer.devices} {platform} device(s), physics {PHYSICS[config.env.impl]}, "
            f"scenario {config.env.scenario}, jets {config.env.jet}, priors "
            f"{', '.join(config.priors) or 'none'}; obs {env.obs_size}, actions {env.action_size}"
        )
        for name, figures in self.priors.items():
            self.progress(
                f"prior {name}: {figures['clips']} clip(s), {figures['seconds']:.1f} s; on one "
                f"foot {figures['single_support_share']:.2f} of the time, "
                f"{figures['contact_switches_per_second']:.2f} contact switches per foot per "
                f"second, soles up to {100 * figures['sole_clearance_max_m']:.1f} cm (the "
                "evaluation's rules)"
            )
        if self.recipe.curriculum:
            self.progress(self._stage_line())

    def _stage_line(self) -> str:
        names = curriculum.stage_names(self.recipe)
        name = names[self.stage.stage]
        stage = self.recipe.curriculum[name]
        changes = {t: getattr(stage, t) for t in ("env", "reward", "ppo", "amp", "priors")}
        changed = "; ".join(f"[{t}] {v}" for t, v in changes.items() if v) or "the recipe as it is"
        return (
            f"curriculum stage {self.stage.stage + 1}/{len(names)} '{name}' since iteration "
            f"{self.stage.since}: {changed}"
        )

    def loop(self, stop: Callable[[dict[str, float]], bool] | None) -> None:
        run = self.recipe.run
        iterations_from = (self.iteration, time.perf_counter())
        while self.iteration < run.iterations:
            if run.max_minutes and time.perf_counter() - self.start > 60 * run.max_minutes:
                self.progress(f"stopped after {run.max_minutes} minutes")
                break
            self._iterate()
            iteration = self.iteration
            if iteration % run.log_every == 0 or iteration == 1:
                left = _time_left(run, iteration, self.start, iterations_from)
                self.progress(_line(iteration, self.last) + left)
            final = iteration >= run.iterations
            evaluated = (run.eval_every and iteration % run.eval_every == 0) or final
            if evaluated:
                self._evaluate()
            figures = curriculum.goal_figures(self.evaluation, self.window) if evaluated else None
            switched = self._advance_stage(figures)
            if evaluated:
                self.window = []
            if iteration % run.checkpoint_every == 0 or final or switched:
                self._save()
            if switched:
                iterations_from = (self.iteration, time.perf_counter())
            if evaluated and stop is not None and stop(self.evaluation):
                self.progress(f"stop criterion met at iteration {iteration}")
                break

    def _iterate(self) -> None:
        tick = time.perf_counter()
        _phases(self.trainer)  # (what an evaluation spent is dropped)
        self.learner, self.carry, metrics = self.trainer.iteration(self.learner, self.carry)
        seconds = time.perf_counter() - tick
        config = self.trainer.config
        self.last = {k: float(v) for k, v in metrics.items()} | {
            "env_steps": float(self.learner.env_steps),
            "env_steps_per_second": config.ppo.num_envs * config.ppo.rollout_steps / seconds,
            "wall_seconds": time.perf_counter() - self.start,
            "stage": float(self.stage.stage),
        }
        phases = _phases(self.trainer)
        if phases:
            phases["update"] = seconds - sum(phases.values())
            self.last |= {f"seconds_{name}": value for name, value in phases.items()}
        self.log.write("train", self.iteration, self.last)
        if self.recipe.curriculum:  # (goals read it; a run without stages keeps none)
            self.window.append(self.last)

    def _evaluate(self) -> None:
        self.evaluation = _evaluate(
            self.trainer, self.learner, self.robot, self.out, self.log, self.progress
        )
        self.evaluated_at = self.iteration

    def _advance_stage(self, evaluation: dict[str, float] | None) -> bool:
        """Go to the next curriculum stage where the current one ends; True if it did."""
        self.stage, why = curriculum.advance(self.recipe, self.stage, self.iteration, evaluation)
        if not why:
            return False
        self.progress(f"curriculum: stage ends at iteration {self.iteration} ({why})")
        _, self.trainer, _ = build_trainer(self.stage_config(), self.robot)
        self.carry = self._new_carry()
        self.progress(self._stage_line())
        return True

    def _save(self) -> None:
        save_checkpoint(self.out / NAME, self.learner)
        if self.recipe.curriculum:
            curriculum.write_state(self.out, self.recipe, self.stage)

    def close(self) -> dict[str, Any]:
        """The last checkpoint and evaluation, and the summary."""
        self._save()
        if self.evaluated_at != self.iteration and self.iteration > 0:
            self._evaluate()
        self.log.close()
        summary = {
            "priors": self.priors,
            "iterations": self.iteration,
            "env_steps": float(self.learner.env_steps),
            "seconds": round(time.perf_counter() - self.start, 2),
            "train": self.last,
            "eval": self.evaluation,
        }
        if self.recipe.curriculum:
            summary["curriculum"] = [dict(s) for s in self.stage.switches]
        write_json_atomic(self.out / "summary.json", summary)
        return summary


def _evaluate(
    trainer: Trainer,
    learner: Learner,
    robot: Robot,
    out: Path,
    log: MetricsLog,
    progress: Callable[[str], None],
) -> dict[str, float]:
    iteration = int(learner.iteration)
    evaluation = run_evaluation(trainer, learner, robot, out, iteration)
    log.write("eval", iteration, evaluation)
    if trainer.config.run.keep_evaluated:
        save_slim(out / "evaluated" / f"iter_{iteration}.msgpack", learner)
    draw_curves(out)
    progress(f"eval {iteration}: " + ", ".join(f"{k[5:]} {v:.3g}" for k, v in evaluation.items()))
    return evaluation


def evaluation_key(seed: int, iteration: int) -> jax.Array:
    """The key of a run's evaluation at `iteration` (train and `train evaluate` alike)."""
    return jax.random.fold_in(jax.random.key(seed + 1), iteration)


def run_evaluation(
    trainer: Trainer, learner: Learner, robot: Robot, out: Path, iteration: int
) -> dict[str, float]:
    config = trainer.config
    key = evaluation_key(config.run.seed, iteration)
    metrics, arrays = evaluate(trainer, learner, key, config.run.eval_rollouts)
    meta = {"iteration": iteration, "scenario": config.env.scenario, "clip": f"iter_{iteration}"}
    save_rollout(
        out / "rollouts" / f"iter_{iteration}.mcap",
        arrays,
        robot,
        config.env.control_hz,
        meta | {"priors": sorted(config.priors)},
        trainer.env.course,
    )
    return metrics


def evaluate_run(
    run: Path,
    robot: Robot,
    prior_share: float = 0.0,
    noise: float = 0.0,
    checkpoint: Path | None = None,
    seed: int | None = None,
    prior: str | None = None,
    air_share: float | None = None,
    stage: str | None = None,
    terrain: str | None = None,
) -> dict[str, float]:
    """A run's latest checkpoint in the evaluation of its config, from other starts or with
    action noise: a way to find out where a policy fails. A run with a curriculum is
    evaluated in the stage of its latest checkpoint (OUT/curriculum.json), or in `stage`.

    Args:
        run: the OUT of `train` (its config.toml and checkpoint.msgpack; the priors' paths of
            the config are read from the current folder, as training read them).
        robot: the robot it was trained for.
        prior_share: the share of starts in prior frames (0: standing, as the run evaluates).
        noise: the action noise in units of the policy's std (0: deterministic).
        checkpoint: another checkpoint of the same config (an earlier one kept aside) instead
            of the run's latest.
        seed: draw the starts and waypoints from this seed instead of the run's (another
            sample of the same evaluation).
        prior: start in the frames of this prior alone (one of the config's; the
            discriminator sees the same policy, the style figures compare with this prior).
        air_share: the chance of an air waypoint instead of the config's air_probability.
        stage: evaluate in this stage of the config's curriculum (the last: the recipe's
            own task).
        terrain: 'KIND[:LEVEL]' (a run of the "terrain" scenario): every robot on that tile
            (without a level, the hardest) of a course that training did not use (the course
            of seed courses.HELD_OUT + `seed`, 0 without one).

    Returns:
        The figures ("eval_" names). With the defaults, those of the run's own evaluation at
        the checkpoint's iteration (its row of eval.csv), drawn with the same key.
    """
    run = Path(run)
    if not (run / "config.toml").is_file():
        raise TrainError(f"{run}: no config.toml (not the OUT of motionkit train?)")
    checkpoint = run / NAME if checkpoint is None else Path(checkpoint)
    if not checkpoint.is_file():
        raise TrainError(f"{checkpoint}: no such checkpoint")
    if not 0.0 <= prior_share <= 1.0 or noise < 0.0:
        raise TrainError(f"prior share {prior_share} must be in [0, 1], noise {noise} >= 0")
    config = _evaluated_stage(run, TrainConfig.from_toml(run / "config.toml"), stage)
    if prior_share > 0 and not config.priors:
        raise TrainError(f"{run}: starts in prior frames need priors, and the run has none")
    if prior is not None:
        if prior not in config.priors:
            known = ", ".join(config.priors) or "none"
            raise TrainError(f"{run}: no prior {prior!r} in its config (its priors: {known})")
        config = replace(config, priors={prior: config.priors[prior]})
    if air_share is not None:
        if not 0.0 <= air_share <= 1.0:
            raise TrainError(f"air share {air_share} must be in [0, 1]")
        config = replace(config, env=replace(config.env, air_probability=air_share))
    tile = None
    if terrain is not None:
        config, tile = held_out_tile(run, config, terrain, seed or 0)
    config, trainer, _ = build_trainer(config, robot, with_priors=prior_share > 0)
    template, _ = trainer.init(config.run.seed)
    learner = trainer.replicate(load_checkpoint(checkpoint, template)[0])
    seed = config.run.seed if seed is None else seed
    key = evaluation_key(seed, int(learner.iteration))
    chunks = config.run.eval_rollouts
    return evaluate(trainer, learner, key, chunks, prior_share, noise, tile)[0]


def held_out_tile(
    run: Path, config: TrainConfig, terrain: str, number: int
) -> tuple[TrainConfig, tuple[int, int]]:
    """The config on the held-out course `number` (`courses.held_out`) and the tile (kind
    index, level) of 'KIND[:LEVEL]'; a TrainError for a run on flat ground or a bad tile."""
    from motionkit.train.env.courses import CourseLayout, held_out, parse_tile

    if config.env.scenario != "terrain":
        raise TrainError(
            f"{run}: --terrain needs a run of the terrain scenario (its policy sees a height "
            f"map); this one trained on {config.env.scenario} ground"
        )
    layout = CourseLayout.of(config.env)
    tile = parse_tile(terrain, layout)
    env = replace(config.env, terrain_seed=held_out(layout, number).seed)
    return replace(config, env=env), tile


def _evaluated_stage(run: Path, config: TrainConfig, stage: str | None) -> TrainConfig:
    """The config of the curriculum stage to evaluate in (the config itself without one)."""
    if stage is not None:
        if stage not in config.curriculum:
            known = ", ".join(config.curriculum) or "none"
            raise TrainError(f"{run}: no curriculum stage {stage!r} (its stages: {known})")
        return config.stage(stage)
    saved = curriculum.read_state(run, config)
    return curriculum.stage_config(config, saved or curriculum.CurriculumState())


def build_trainer(
    config: TrainConfig, robot: Robot, with_priors: bool = True
) -> tuple[TrainConfig, Trainer, dict[str, dict[str, float]]]:
    """The config with its physics resolved for this machine, its trainer (the environment
    resetting from the priors' frames unless `with_priors` is False) and the priors' summary."""
    config = replace(config, env=replace(config.env, impl=resolve_impl(config.env.impl)))
    priors = config.priors if with_priors else {}
    mirror = None
    if config.amp.mirror:
        try:
            mirror = robot_mirror(robot)
        except RobotModelError as exc:
            raise TrainError(f"[amp] mirror needs the robot's mirror: {exc}") from exc
    prior, summary = load_priors(priors, robot, config.env.control_hz, mirror)
    return config, Trainer(config, make_env(config, robot, prior)), summary


def _phases(trainer: Trainer) -> dict[str, float]:
    """Seconds per rollout phase since the last call (MuJoCo backend; {} on MJX)."""
    clock = getattr(trainer, "clock", None)
    return {} if clock is None else clock.read()


def _time_left(run: RunConfig, iteration: int, start: float, since: tuple[int, float]) -> str:
    """', about M min left' at the pace since `since` (iteration, time), within max_minutes."""
    done = iteration - since[0]
    if done < 1:
        return ""
    now = time.perf_counter()
    left = (run.iterations - iteration) * (now - since[1]) / done
    if run.max_minutes:
        left = min(left, 60 * run.max_minutes - (now - start))
    return f", about {max(left, 0.0) / 60:.1f} min left"


def _line(iteration: int, m: dict[str, float]) -> str:
    nan = float("nan")
    disc = m.get("disc_policy_accuracy_rollout", nan)
    return (
        f"iter {iteration}: reward {m['reward']:.3f} (task {m['task_reward']:.3f}, style "
        f"{m['style_reward']:.3f}), episode {m['episode_seconds']:.2f} s, falls/episode "
        f"{m['falls_per_episode']:.2f}, waypoints {m['waypoints_per_episode']:.2f} (air "
        f"{m.get('air_waypoints_per_episode', nan):.2f}), speed {m['approach_speed']:.2f} m/s, "
        f"airborne {m['airborne_share']:.2f}, disc accuracy "
        f"{disc:.2f}, lr {m['learning_rate']:.2e}, kl {m['kl']:.4f}, "
        f"{m['env_steps_per_second']:.0f} env-steps/s"
    )
