"""The pipeline's stages, in order: retarget, trajopt, jet_ident, datasets, train. Each
computes its key from what it reads (the robot's model hash included where it uses the robot),
then runs (or is found cached) through `run_cached`; every stage of a run uses its one robot."""

from __future__ import annotations

import json
import os
import shutil
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import TYPE_CHECKING

from motionkit.core.errors import PipelineError
from motionkit.files.digests import code_digest, digest, file_digest, versions
from motionkit.files.outputs import write_text_atomic
from motionkit.pipeline.cache import Outcome, run_cached
from motionkit.pipeline.config import PipelineConfig
from motionkit.robot import Robot
from motionkit.runtime.progress import Progress, silent

if TYPE_CHECKING:
    from motionkit.trajopt.config import TrajoptConfig
    from motionkit.trajopt.runner import Outcome as TrajoptOutcome

JAX = ("jax", "jaxlib", "flax", "optax")
# the modules the jet-ident stage's work runs (the key hashes them and what they import)
JET_IDENT_CODE = (
    "motionkit.jet_ident.benchlog",
    "motionkit.jet_ident.fit",
    "motionkit.jet_ident.synthetic",
)


@dataclass
class Context:
    config: PipelineConfig
    out: Path
    robot: Robot
    mocap_dir: Path | None = None
    full: bool = False
    force: bool = False
    fetch: bool = False  # retarget the fetch recipe's CMU clips (downloaded) instead
    cluster: str | None = None  # a Ray cluster for the retarget clips and the trajopt library
    keys: dict[str, str] = field(default_factory=dict)  # stage -> key, as the stages run
    progress: Progress = silent  # receives the stages' lines

    @property
    def records(self) -> Path:
        return self.out / ".pipeline"

    def folder(self, name: str) -> Path:
        return self.out / name

    def run(self, stage: str, parts: tuple, folder: str, work: Callable[[Path], str]) -> Outcome:
        key = digest(stage, *parts)
        self.keys[stage] = key
        return run_cached(stage, key, self.folder(folder), self.records, work, self.force)


class DryRun(Context):
    """A context in which the stages load and check their recipes and inputs and compute
    their keys, but run nothing: a bad recipe is found before OUT is written to."""

    def run(self, stage: str, parts: tuple, folder: str, work: Callable[[Path], str]) -> Outcome:
        key = digest(stage, *parts)
        self.keys[stage] = key
        return Outcome(stage, "checked", 0.0, "", str(self.folder(folder)), key)


def _retarget_recipe(ctx: Context) -> str:
    if not ctx.fetch:
        return ctx.config.retarget.recipe
    if not ctx.config.retarget.fetch_recipe:
        raise PipelineError(f"{ctx.config.source}: --fetch needs [retarget] fetch_recipe")
    return ctx.config.retarget.fetch_recipe


def retarget(ctx: Context) -> Outcome:
    from motionkit.retarget.batch import resolve_inputs, run_retarget
    from motionkit.retarget.config import RetargetConfig

    recipe = ctx.config.resolve("retarget", _retarget_recipe(ctx))
    config = RetargetConfig.from_toml(recipe)
    if ctx.mocap_dir is not None:
        if not ctx.mocap_dir.is_dir():
            raise PipelineError(f"--mocap-dir {ctx.mocap_dir}: no such folder")
        inputs = [str(ctx.mocap_dir)]
    else:  # the recipe's clips: files beside it, or CMU ids fetched into the cache
        inputs = [
            str(recipe.parent / c) if (recipe.parent / c).exists() else c for c in config.clips
        ]
    clips = resolve_inputs(inputs)
    config = replace(config, clips=())
    files = [
        (clip.name, file_digest(clip.path), file_digest(clip.asf) if clip.asf else None)
        for clip in clips
    ]
    parts = (
        files,
        config.to_dict(),
        ctx.robot.model_hash,
        code_digest("motionkit.retarget.batch"),
        versions("placo", "pin"),
    )

    def work(folder: Path) -> str:
        jobs = ctx.config.retarget.jobs or os.cpu_count() or 1
        results = run_retarget(
            clips, folder, config, jobs, ctx.robot, ctx.cluster, progress=ctx.progress
        )
        failed = [r for r in results if r.output is None]
        if failed:
            raise PipelineError(
                f"retarget: {len(failed)} of {len(results)} clip(s) failed: "
                + "; ".join(f"{r.name}: {r.error}" for r in failed)
            )
        frames = sum(r.frames for r in results)
        return f"{len(results)} walking clips, {frames} frames"

    return ctx.run("retarget", parts, "walk", work)


TRAJOPT_CLIPS = "trajopt_clips"  # OUT/.pipeline/trajopt_clips: every flight solved, kept


def trajopt(ctx: Context) -> Outcome:
    """The recipe flights and the flight library in one batch of solves. Each clip is written
    as it is solved into the stage's clip cache (OUT/.pipeline/trajopt_clips, with its key),
    which outlives a failed or interrupted stage: a rerun solves only the clips that are
    missing there or out of date, then copies the stage's clips into its folder."""
    from motionkit.trajopt.config import TrajoptConfig
    from motionkit.trajopt.library import read_library

    stage = ctx.config.trajopt
    configs = {}
    for recipe in (ctx.config.resolve("trajopt", r) for r in stage.recipes):
        config = TrajoptConfig.from_toml(recipe)
        configs[recipe.stem] = replace(config, solver=replace(config.solver, print_level=0))
    library = ctx.config.resolve("trajopt", stage.library) if stage.library else None
    solves = read_library(library) if library else []
    clashing = sorted(set(configs) & {s.name for s in solves})
    if clashing:
        raise PipelineError(f"[trajopt] recipe flights and library clips both named {clashing}")
    parts = (
        {name: c.to_dict() for name, c in configs.items()},
        {s.name: s.config.to_dict() for s in solves},
        stage.replay,
        stage.min_solved_share,
        ctx.robot.model_hash,
        code_digest("motionkit.trajopt.runner", "motionkit.trajopt.library"),
        versions("casadi", "adam-robotics", "mujoco"),
    )

    def work(folder: Path) -> str:
        return _solve_flights(ctx, configs, library, folder)

    return ctx.run("trajopt", parts, "flight", work)


def _solve_flights(
    ctx: Context, flights: dict[str, TrajoptConfig], library: Path | None, folder: Path
) -> str:
    """Solve the recipe `flights` and the `library` into the clip cache, copy the solved
    clips into `folder`; the stage's line, or PipelineError when too few solved."""
    from motionkit.trajopt.runner import Task, library_tasks, solve_batch

    stage = ctx.config.trajopt
    tasks = [Task(c.to_dict(), name, stage.replay, ctx.robot) for name, c in flights.items()]
    configs = list(flights.values())
    if library is not None:
        more, more_configs = library_tasks(library, ctx.robot, stage.replay, True, ctx.progress)
        tasks, configs = tasks + more, configs + more_configs
    cache = ctx.records / TRAJOPT_CLIPS
    jobs = stage.jobs or os.cpu_count() or 1
    outcomes = solve_batch(tasks, configs, cache, jobs, cluster=ctx.cluster, resume=True,
                           progress=ctx.progress)  # fmt: skip
    failed = [o for o in outcomes if not o.solved]
    for outcome in failed:
        ctx.progress(f"trajopt: {outcome.name} failed: {outcome.text}")
    count = len(flights)
    library_outcomes = outcomes[count:]
    shortfall = _shortfall(
        outcomes[:count], library_outcomes, configs[count:], stage.min_solved_share
    )
    solved = [o for o in outcomes if o.solved]
    if shortfall:
        raise PipelineError(
            f"trajopt: {'; '.join(shortfall)}; failed: "
            + "; ".join(f"{o.name}: {o.text}" for o in failed)
            + f" ({len(solved)} solved clips kept in {cache}: the next run solves only the rest)"
        )
    _copy_clips(cache, folder, [o.name for o in solved])
    made = [f"{len(flights)} flight(s) ({', '.join(flights)})"] if flights else []
    if library is not None:
        done = [o for o in library_outcomes if o.solved]
        airborne = sum(o.figures["airborne_s"] for o in done)
        made.append(
            f"{len(done)} of {len(library_outcomes)} library clips ({airborne:.0f} s airborne)"
        )
    solve_s = sum(o.figures["solve_s"] for o in solved)
    line = f"{' and '.join(made)}, IPOPT {solve_s:.0f} s, checked"
    if failed:
        line += f"; {len(failed)} failed: {', '.join(o.name for o in failed)} (--force retries)"
    return line


def _shortfall(
    flights: list[TrajoptOutcome],
    clips: list[TrajoptOutcome],
    configs: list[TrajoptConfig],
    share: float,
) -> list[str]:
    """Why the solves fall short of the stage's rule (none: they do not): a recipe flight that
    failed, or a kind of library clip with less than `share` of its clips solved."""
    reasons = [f"flight '{o.name}' failed" for o in flights if not o.solved]
    kinds: dict[str, list[bool]] = {}
    for outcome, config in zip(clips, configs, strict=True):
        kinds.setdefault(config.kind, []).append(outcome.solved)
    for kind, solved in sorted(kinds.items()):
        if sum(solved) < share * len(solved):
            reasons.append(
                f"{sum(solved)} of {len(solved)} {kind} clips solved (at least {share:.0%} needed)"
            )
    return reasons


def _copy_clips(cache: Path, folder: Path, names: list[str]) -> None:
    """The files of the solved clips `names`, from the clip cache into the stage's folder."""
    from motionkit.trajopt.runner import clip_files

    for name in clip_files(names):
        shutil.copyfile(cache / name, folder / name)


def jet_ident(ctx: Context) -> Outcome:
    from motionkit.jet_ident.config import JetIdentConfig

    config = JetIdentConfig.from_toml(ctx.config.resolve("jet_ident", ctx.config.jet_ident.recipe))
    parts = (config.to_dict(), code_digest(*JET_IDENT_CODE), versions(*JAX))

    def work(folder: Path) -> str:
        from motionkit.jet_ident.benchlog import write_log
        from motionkit.jet_ident.fit import LSTM, fit_logs
        from motionkit.jet_ident.synthetic import synthetic_run

        logs = []
        for seed in config.bench.train_seeds:
            logs.append(folder / "logs" / f"p250_{seed}.csv")
            write_log(logs[-1], synthetic_run(config.bench, seed).log)
            ctx.progress(f"simulated bench log {logs[-1].name}")
        report = fit_logs(logs, folder, config, progress=ctx.progress)
        lstm = report["metrics"][LSTM]
        return (
            f"LSTM thrust model from {len(logs)} bench logs: free-run MAE {lstm['mae']:.2f} N, "
            f"RMSE {lstm['rmse']:.2f} N"
        )

    return ctx.run("jet_ident", parts, "jet", work)


def datasets(ctx: Context) -> Outcome:
    keys = (ctx.keys["retarget"], ctx.keys["trajopt"])
    parts = (
        keys,
        ctx.robot.model_hash,
        code_digest("motionkit.dataset.collection", "motionkit.dataset.validate"),
    )

    def work(folder: Path) -> str:
        from motionkit.dataset.collection import MotionDataset
        from motionkit.dataset.validate import validate_clip

        robot = ctx.robot
        dataset = MotionDataset([ctx.folder("walk"), ctx.folder("flight")])
        rows = []
        for clip in dataset.clips:
            checks = validate_clip(clip.path, robot)
            failed = [c for c in checks if not c.ok and not c.warning]
            if failed:
                raise PipelineError(
                    f"datasets: {clip.path} fails "
                    + "; ".join(f"{c.name}: {c.detail}" for c in failed)
                )
            physics = clip.metadata.metrics.get("physics", {})
            rows.append(
                {"clip": str(clip.path), "kind": clip.label, "frames": clip.frames,
                 "duration_s": round(clip.duration, 3), "rate_hz": round(clip.rate, 3),
                 "physics": {k: physics.get(k) for k in PHYSICS_FIGURES}}
            )  # fmt: skip
        for line in physics_lines(rows):
            ctx.progress(line)
        seconds: dict[str, float] = {}
        for row in rows:
            seconds[row["kind"]] = seconds.get(row["kind"], 0.0) + row["duration_s"]
        index = {"clips": rows, "seconds_per_kind": seconds, "robot_hash": robot.model_hash}
        write_text_atomic(folder / "index.json", json.dumps(index, indent=2) + "\n")
        kinds = ", ".join(f"{k} {v:.1f} s" for k, v in sorted(seconds.items()))
        return f"{len(rows)} clips valid ({kinds})"

    return ctx.run("datasets", parts, "datasets", work)


# the physics figures of each clip (its generator's check) in the datasets stage's table
PHYSICS_FIGURES = (
    "cop_inside_share_single_support",
    "torque_within_share",
    "friction_within_share",
    "residual_force_p95_bw",
)


def physics_lines(rows: list[dict]) -> list[str]:
    """One line per clip: the physics figures its generator stored (- where it has none)."""
    lines = [f"{'clip':<34} {'kind':<8} {'seconds':>7} {'CoP in 1':>9} {'tau ok':>7} "
             f"{'mu ok':>6} {'resid p95':>10}"]  # fmt: skip
    for row in rows:
        cells = [
            "-" if row["physics"][k] is None else f"{row['physics'][k]:.3f}"
            for k in PHYSICS_FIGURES
        ]
        lines.append(
            f"{Path(row['clip']).stem[:33]:<34} {row['kind']:<8} {row['duration_s']:>7.2f} "
            f"{cells[0]:>9} {cells[1]:>7} {cells[2]:>6} {cells[3]:>10}"
        )
    lines.append(
        "CoP in 1: single-support frames whose needed centre of pressure is in the stance sole; "
        "tau ok: frames within the effort limits; mu ok: within the friction pyramid; resid p95: "
        "the base force contacts and thrust cannot explain [body weights] (flights: at the knots)"
    )
    return lines


def train(ctx: Context) -> Outcome:
    from motionkit.train.config import PriorConfig, TrainConfig

    stage = ctx.config.train
    config = TrainConfig.from_toml(
        ctx.config.resolve("train", stage.full_recipe if ctx.full else stage.recipe)
    )
    priors = {  # the recipe's weights, this run's clips
        name: PriorConfig(
            (str(ctx.folder(name)),), config.priors[name].weight if name in config.priors else 1.0
        )
        for name in ("walk", "flight")
    }
    env = config.env
    if stage.jet == "lstm":
        model = ctx.folder("jet") / "model.npz"
        env = replace(env, jet="lstm", jet_model=str(model), initial_thrust=(0.0, 0.0))
    config = replace(config, env=env, priors=priors)
    parts = (
        config.to_dict(),
        [ctx.keys[s] for s in ("retarget", "trajopt", "jet_ident", "datasets")],
        ctx.robot.model_hash,
        code_digest("motionkit.train.runner"),
        versions(*JAX, "mujoco", "mujoco-mjx"),
    )

    def work(folder: Path) -> str:
        from motionkit.train.runtime import enable_compile_cache, require_train_extra

        require_train_extra()
        from motionkit.train.runner import train as train_policy

        enable_compile_cache()
        summary = train_policy(config, folder, ctx.robot, progress=ctx.progress)
        last = summary["train"]
        return (
            f"{summary['iterations']} iterations, {summary['env_steps']:.0f} env steps; "
            f"last reward {last['reward']:.3f} (task {last['task_reward']:.3f}, style "
            f"{last['style_reward']:.3f})"
        )

    return ctx.run("train", parts, "train", work)


STAGE_FOLDERS = ("walk", "flight", "jet", "datasets", "train")  # the stages', in order
STAGES: tuple[tuple[str, Callable[[Context], Outcome]], ...] = (
    ("retarget", retarget),
    ("trajopt", trajopt),
    ("jet_ident", jet_ident),
    ("datasets", datasets),
    ("train", train),
)
