"""A training run in a folder: config, metrics logs, checkpoints, evaluations and rollouts.

OUT/config.toml             the resolved config (and the priors used)
OUT/train.csv, eval.csv     metrics per iteration / per evaluation (+ OUT/tensorboard/)
OUT/checkpoint.msgpack      the latest learner (resume with resume=True)
OUT/evaluated/iter_N.msgpack  with [run] keep_evaluated: a slim checkpoint of every evaluation
OUT/rollouts/iter_N.mcap    the first evaluation episode of environment 0, for the viewer
OUT/summary.json            priors, last training and evaluation figures, timings
OUT/curves.png              the training curves (redrawn at every evaluation)
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path
from typing import Any

import jax

from motionkit.core.errors import TrainError
from motionkit.files.outputs import check_out, claim_out, write_json_atomic, write_text_atomic
from motionkit.robot import Robot
from motionkit.runtime.progress import Progress, silent
from motionkit.train.amp import PriorData
from motionkit.train.checkpoint import NAME, load_checkpoint, save_checkpoint, save_slim
from motionkit.train.config import RunConfig, TrainConfig
from motionkit.train.curves import draw_curves
from motionkit.train.devices import resolve_devices, resolve_impl
from motionkit.train.env import Env
from motionkit.train.evaluate import evaluate, save_rollout
from motionkit.train.learner import Learner, Trainer
from motionkit.train.metrics_log import MetricsLog
from motionkit.train.priors import load_priors

PHYSICS = {
    "jax": "MJX (JAX)",
    "warp": "MJX (MuJoCo Warp)",
    "mujoco": "MuJoCo C (mujoco.batch)",
}
# what a run writes in its folder (see the module doc)
OUTPUTS = (
    "config.toml", "train.csv", "eval.csv", "tensorboard", NAME, "rollouts", "summary.json",
    "curves.png", "evaluated",
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
    progress: Progress = silent,
    stop: Callable[[dict[str, float]], bool] | None = None,
) -> dict[str, Any]:
    """Train (or resume) in `out`; returns the summary also written to OUT/summary.json.

    A run stopped by `max_minutes` (counted from the call, setup and compilation included) is
    evaluated before it returns, like one that completes its iterations. The folder's files
    are listed in the module doc.

    Args:
        config: the training config; its [priors] tables name the motion priors.
        out: the run's folder (OUT).
        robot: the robot to train.
        resume: continue the run in `out` from its checkpoint; False needs a folder without
            one.
        jets_at_rest: on resuming, set the policy's jet outputs to the rest action (for a
            checkpoint trained with another jet action, `Trainer.jets_at_rest`).
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
    start = time.perf_counter()
    out = Path(out)
    checkpoint = out / NAME
    if resume and not checkpoint.exists():
        raise TrainError(f"{out}: nothing to resume (no {NAME})")
    if not resume and checkpoint.exists():
        raise TrainError(f"{out} holds a run already: pass --resume or another --out")
    check_out(out, OUTPUTS, TrainError)
    config, trainer, prior_summary = build_trainer(config, robot)
    env, run = trainer.env, config.run
    learner, carry = trainer.init(run.seed)
    if resume:  # checked before anything is written
        restored, slim = load_checkpoint(checkpoint, learner)
        if jets_at_rest:
            restored = trainer.jets_at_rest(restored)
        learner = trainer.replicate(restored)
        key = jax.random.fold_in(jax.random.key(run.seed), int(learner.iteration))
        carry = trainer.new_carry(*jax.random.split(key))
    claim_out(out, OUTPUTS, TrainError)
    write_text_atomic(out / "config.toml", config.to_toml())
    if resume:
        moments = " (a slim checkpoint: the optimisers' moments start afresh)" if slim else ""
        progress(f"resumed {out} at iteration {int(learner.iteration)}{moments}")
        if jets_at_rest:
            progress(f"the policy's jet outputs start at rest ({config.env.jet_action} action)")
    log = MetricsLog(out, run.tensorboard)
    if log.note:
        progress(log.note)
    platform = trainer.mesh.devices.flat[0].platform
    progress(
        f"{config.ppo.num_envs} envs x {config.ppo.rollout_steps} steps per iteration on "
        f"{trainer.devices} {platform} device(s), physics {PHYSICS[config.env.impl]}, "
        f"scenario {config.env.scenario}, jets {config.env.jet}, priors "
        f"{', '.join(config.priors) or 'none'}; obs {env.obs_size}, actions {env.action_size}"
    )
    for name, figures in prior_summary.items():
        progress(
            f"prior {name}: {figures['clips']} clip(s), {figures['seconds']:.1f} s; on one foot "
            f"{figures['single_support_share']:.2f} of the time, "
            f"{figures['contact_switches_per_second']:.2f} contact switches per foot per second, "
            f"soles up to {100 * figures['sole_clearance_max_m']:.1f} cm (the evaluation's rules)"
        )
    summary: dict[str, Any] = {"priors": prior_summary}
    last: dict[str, float] = {}
    evaluation: dict[str, float] = {}
    evaluated_at = -1
    steps_per_iteration = config.ppo.num_envs * config.ppo.rollout_steps
    iterations_from = (int(learner.iteration), time.perf_counter())
    while int(learner.iteration) < run.iterations:
        if run.max_minutes and time.perf_counter() - start > 60 * run.max_minutes:
            progress(f"stopped after {run.max_minutes} minutes")
            break
        tick = time.perf_counter()
        phases = _phases(trainer)  # (what an evaluation spent is dropped)
        learner, carry, metrics = trainer.iteration(learner, carry)
        iteration = int(learner.iteration)
        last = {k: float(v) for k, v in metrics.items()}
        seconds = time.perf_counter() - tick
        last |= {
            "env_steps": float(learner.env_steps),
            "env_steps_per_second": steps_per_iteration / seconds,
            "wall_seconds": time.perf_counter() - start,
        }
        phases = _phases(trainer)
        if phases:
            phases["update"] = seconds - sum(phases.values())
            last |= {f"seconds_{name}": value for name, value in phases.items()}
        log.write("train", iteration, last)
        if iteration % run.log_every == 0 or iteration == 1:
            progress(_line(iteration, last) + _time_left(run, iteration, start, iterations_from))
        final = iteration >= run.iterations
        evaluated = (run.eval_every and iteration % run.eval_every == 0) or final
        if evaluated:
            evaluation = _evaluate(trainer, learner, robot, out, log, progress)
            evaluated_at = iteration
        if iteration % run.checkpoint_every == 0 or final:
            save_checkpoint(checkpoint, learner)
        if evaluated and stop is not None and stop(evaluation):
            progress(f"stop criterion met at iteration {iteration}")
            break
    save_checkpoint(checkpoint, learner)
    if evaluated_at != int(learner.iteration) and int(learner.iteration) > 0:
        evaluation = _evaluate(trainer, learner, robot, out, log, progress)
    log.close()
    summary |= {
        "iterations": int(learner.iteration),
        "env_steps": float(learner.env_steps),
        "seconds": round(time.perf_counter() - start, 2),
        "train": last,
        "eval": evaluation,
    }
    write_json_atomic(out / "summary.json", summary)
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
) -> dict[str, float]:
    """A run's latest checkpoint in the evaluation of its config, from other starts or with
    action noise: a way to find out where a policy fails.

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
    config = TrainConfig.from_toml(run / "config.toml")
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
    config, trainer, _ = build_trainer(config, robot, with_priors=prior_share > 0)
    template, _ = trainer.init(config.run.seed)
    learner = trainer.replicate(load_checkpoint(checkpoint, template)[0])
    seed = config.run.seed if seed is None else seed
    key = evaluation_key(seed, int(learner.iteration))
    chunks = config.run.eval_rollouts
    return evaluate(trainer, learner, key, chunks, prior_share, noise)[0]


def build_trainer(
    config: TrainConfig, robot: Robot, with_priors: bool = True
) -> tuple[TrainConfig, Trainer, dict[str, dict[str, float]]]:
    """The config with its physics resolved for this machine, its trainer (the environment
    resetting from the priors' frames unless `with_priors` is False) and the priors' summary."""
    config = replace(config, env=replace(config.env, impl=resolve_impl(config.env.impl)))
    priors = config.priors if with_priors else {}
    prior, summary = load_priors(priors, robot, config.env.control_hz)
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
