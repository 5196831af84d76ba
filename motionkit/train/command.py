"""`motionkit train` and `motionkit train ablation`: thin wrappers over motionkit.train."""

from __future__ import annotations

import argparse
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path

from motionkit.cli import recipe_argument
from motionkit.core.errors import TrainError
from motionkit.files.outputs import check_out
from motionkit.robot import load_robot
from motionkit.train.runtime import enable_compile_cache, require_train_extra

PRIOR_CHOICES = "walk,flight|walk|flight|none"

EPILOG = """\
The config is a TOML recipe with tables [env], [reward], [ppo], [amp], [run] and one
[priors.NAME] table per motion prior, e.g.
  [priors.walk]
  paths = ["datasets/walk"]        # MCAP clips or folders (relative to the working directory)
  weight = 1.0
A curriculum is a [curriculum.NAME] table per stage, in order; each changes keys of [env],
[reward], [ppo] and [amp] and the priors' weights, and ends at the first evaluation that meets
its goals (or after max_iterations in it), e.g.
  [curriculum.walk]
  env = { air_probability = 0.0 }
  ppo = { init_std = 0.1 }
  goals = { eval_approach_speed = ">= 0.3", eval_falls_per_episode = "<= 0.05" }
  max_iterations = 4000
The run logs each switch, and --resume goes on in the stage its checkpoint was saved in.
Recipes (`motionkit recipes train`): walk_fly_cpu (walking, flying and switching from a fresh
policy, curriculum and all: hours on a CPU, resumable), walk_cpu and fly_cpu (parts of the
earlier hand-made runs), walk_gpu, fly_gpu, walk_fly_gpu (the same on one GPU, in 7-minute
calls), paper_gpu (the paper's settings) and tiny_cpu (seconds per iteration). A key left out
keeps its default.
Physics ([env] impl): "auto" (the default) is MuJoCo MJX on a GPU and MuJoCo C (mujoco.batch,
every core) on a CPU; "jax", "warp" and "mujoco" choose one. The run prints which it used.

Outputs in --out: config.toml (resolved), train.csv and eval.csv (metrics per iteration and
per evaluation), tensorboard/ (with tensorboardX installed), checkpoint.msgpack (the latest
learner; --resume continues from it), rollouts/iter_N.mcap (the first evaluation episode, with
its waypoints in the metadata, for `motionkit view`), summary.json, curriculum.json (the stage
the checkpoint is in, and each switch).

Evaluation figures: waypoints reached per episode, share of time airborne and on the ground,
thrust usage (mean T / T_max), falls per episode, episode duration.

  motionkit train --config tiny_cpu --out runs/tiny --priors none
  motionkit train --config walk_fly_cpu --out runs/wf --seed 0   # then --resume to go on
  motionkit train --config paper_gpu --out runs/paper
  motionkit train --config paper_gpu --out runs/paper2 --devices 2   # 2 GPUs of this host
  motionkit train ablation --config paper_gpu --out runs/ablation"""


def add_commands(
    stages: argparse._SubParsersAction, robot_source: Callable[[argparse.ArgumentParser], None]
) -> None:
    parser = stages.add_parser(
        "train",
        help="train the walking-and-flying AMP policy (PPO + discriminator)",
        description="Train one policy that imitates the walking and flying priors (AMP style "
        "reward) and reaches waypoints on the ground and in the air (task reward), on the "
        "robot's MJCF in MuJoCo MJX (GPU) or MuJoCo C (CPU). `motionkit train ablation` runs "
        "the four prior settings.",
        epilog=EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    _common(parser, robot_source, required=False)
    parser.add_argument("--resume", action="store_true", help="continue the run in --out")
    parser.add_argument(
        "--resume-from",
        type=Path,
        metavar="CHECKPOINT",
        help="continue from this checkpoint file (full or slim; from another run folder or "
        "machine) in --out, which gets a copy of it",
    )
    parser.add_argument(
        "--init-from",
        metavar="POLICY",
        help="a new run whose actor starts as this policy's (a shipped name such as walk_fly, "
        "an exported policy folder or a run folder): its layers and observation normaliser; "
        "the critic, action std and discriminator start afresh. A flat-ground policy is "
        "widened to a terrain recipe's height map (it acts as before on flat ground)",
    )
    parser.add_argument(
        "--jets-at-rest",
        action="store_true",
        help="with --resume-from: the policy's jet outputs start at the rest action (their "
        "weights zero), for a checkpoint trained with another [env] jet_action; the rest of "
        "what it learned is kept",
    )
    parser.set_defaults(handler=_train)
    actions = parser.add_subparsers(dest="train_command", metavar="ACTION")
    _add_ablation(actions, robot_source)
    export = actions.add_parser(
        "export",
        help="write a run's policy as a small package for `motionkit play` (at most 2 MB)",
        description="Write the policy of a training run into POLICY_DIR: the actor's parameters "
        "and the observation normaliser (policy.msgpack; no critic, discriminator or optimiser "
        "state), the robot layout it acts for (policy.json), the resolved config (config.toml: "
        "environment, reward, action mapping), the run's last figures (summary.json) and, for "
        "fitted jets, their model (jet_model.npz). A package over 2 MB is refused.",
    )
    export.add_argument("run", type=Path, metavar="RUN_DIR", help="OUT of `motionkit train`")
    export.add_argument("--out", type=Path, required=True, help="policy folder (required)")
    export.add_argument(
        "--half",
        action="store_true",
        help="store the actor's weights as float16 (half the size; actions within about 1e-3)",
    )
    export.add_argument(
        "--checkpoint",
        type=Path,
        metavar="FILE",
        help="export this checkpoint of the run (RUN_DIR/evaluated/iter_N.msgpack, say) "
        "instead of its latest; summary.json then holds that iteration's figures",
    )
    robot_source(export)
    export.set_defaults(handler=_export)
    evaluation = actions.add_parser(
        "evaluate",
        help="evaluate a run's policy again, from other starts or with action noise",
        description="Evaluate the latest checkpoint of a training run as its evaluations do "
        "(deterministic, from standing starts: with no options, its last row of eval.csv "
        "again), or from starts in prior frames and with action noise, to find out where the "
        "policy fails: a policy that walks from prior frames with noise but not from standing "
        "without it has learnt to carry a gait on, not to start one. Prints the figures; "
        "writes nothing.",
    )
    evaluation.add_argument("run", type=Path, metavar="RUN_DIR", help="OUT of `motionkit train`")
    evaluation.add_argument(
        "--prior-starts",
        type=float,
        default=0.0,
        metavar="SHARE",
        help="share of starts in prior frames, 0-1 (default 0: standing; the priors' paths "
        "are read from this folder, as the run read them)",
    )
    evaluation.add_argument(
        "--noise",
        type=float,
        default=0.0,
        help="action noise in units of the policy's std (default 0: deterministic; 1: as it "
        "trains)",
    )
    evaluation.add_argument(
        "--checkpoint",
        type=Path,
        metavar="FILE",
        help="evaluate this checkpoint of the run (one kept aside from an earlier iteration) "
        "instead of its latest",
    )
    evaluation.add_argument(
        "--seed",
        type=int,
        help="draw the starts and waypoints from this seed, not the run's: another sample of "
        "the same evaluation, to see how much its figures vary",
    )
    evaluation.add_argument(
        "--prior",
        metavar="NAME",
        help="start in the frames of this prior alone (with --prior-starts; e.g. flight: "
        "from flight states)",
    )
    evaluation.add_argument(
        "--air-share",
        type=float,
        metavar="P",
        help="the chance of an air waypoint, 0-1, instead of the config's air_probability",
    )
    evaluation.add_argument(
        "--stage",
        metavar="NAME",
        help="with a curriculum: evaluate in this stage's config (default: the stage of the "
        "run's latest checkpoint; the last stage is the recipe's own task)",
    )
    evaluation.add_argument(
        "--terrain",
        metavar="KIND[:LEVEL]",
        help="a terrain run: every robot on this tile (flat, rough, stones or pits; without a "
        "level, the hardest) of a course training did not use (held-out course --seed, 0 "
        "without it)",
    )
    evaluation.add_argument(
        "--per-tile",
        action="store_true",
        help="a terrain run: evaluate every kind x level of a held-out course (--seed picks "
        "it), --robots robots per row, one episode each, and print a table: waypoints, "
        "success (the route reached, none missed, no fall), falls, airborne share on the way "
        "and over holes, thrust per metre, speed",
    )
    evaluation.add_argument(
        "--robots", type=int, default=512, help="robots per row of --per-tile (default 512)"
    )
    robot_source(evaluation)
    evaluation.set_defaults(handler=_evaluate)
    curves = actions.add_parser(
        "curves",
        help="draw a run's training curves (RUN_DIR/curves.png)",
        description="Draw RUN_DIR/train.csv and eval.csv as one PNG of nine panels over "
        "env-steps: speed toward the waypoint, single support, contact switches, falls and "
        "waypoints per episode, airborne share, thrust usage, the discriminator's accuracy, "
        "task and style reward. A run redraws it at every evaluation; this redraws it (or "
        "draws it elsewhere with --out) for a run in progress or one from before.",
    )
    curves.add_argument("run", type=Path, metavar="RUN_DIR", help="OUT of `motionkit train`")
    curves.add_argument("--out", type=Path, help="PNG to write (default RUN_DIR/curves.png)")
    curves.set_defaults(handler=_curves)


def _add_ablation(
    actions: argparse._SubParsersAction, robot_source: Callable[[argparse.ArgumentParser], None]
) -> None:
    """`motionkit train ablation`."""
    ablation = actions.add_parser(
        "ablation",
        help="train walk+flight, walk, flight and no prior over seeds; table, radar, curves",
        description="Run the paper's prior ablation: the same config trained with both priors "
        "(walk+flight), walk only, flight only and no prior (none), each with every seed of "
        "--seeds, into OUT/<arm>/seed_<s>/ ('+' as '_'), one run at a time, seed-major (every "
        "arm with the first seed, then the next), so that a call cut short has one seed of "
        "every arm first. A prior an arm drops is dropped from the curriculum stages' weights "
        "too. After each run and at the end it writes OUT/ablation.json (every run's final "
        "evaluation, per arm and seed), OUT/ablation.md (the table, also printed: per arm the "
        "mean [min, max] over its finished runs of the episode duration over the maximum "
        "episode length, the task reward over the largest of the runs, the thrust usage "
        "1 - T/T_max (1: jets off), waypoints per episode, airborne share on the way to ground "
        "and to air waypoints, falls per episode), OUT/ablation.png (the radar chart of the "
        "first three: per arm the mean and a min-max band) and OUT/ablation_curves.png (every "
        "run's evaluations over env-steps, per arm the mean and min-max band).",
        epilog="""\
Resuming: an OUT that holds runs is refused without --resume. With it, a finished run
(summary.json, and its checkpoint at [run] iterations) is kept, an unfinished one (a
checkpoint short of them: stopped by [run] max_minutes, by --max-minutes or interrupted)
goes on from its checkpoint, and one not begun starts. [run] max_minutes bounds each
run's part of a call; --max-minutes bounds the whole call: the run in training when it
is spent stops (its checkpoint saved, evaluated) and no run starts after it.

  motionkit train ablation --config walk_fly_cpu --seeds 0,1 --out runs/ablation --max-minutes 120
  motionkit train ablation --config walk_fly_cpu --seeds 0,1 --out runs/ablation --resume
  motionkit train ablation --config paper_gpu --seeds 0,1,2 --out runs/ablation_gpu""",
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    _common(ablation, robot_source, priors=False)
    ablation.add_argument(
        "--seeds",
        type=_seeds,
        metavar="S,S,...",
        help="comma-separated seeds; each arm trains once per seed (default: --seed, or the "
        "config's [run] seed)",
    )
    ablation.add_argument(
        "--resume",
        action="store_true",
        help="go on with the runs in --out: keep the finished, resume the unfinished",
    )
    ablation.add_argument(
        "--max-minutes",
        type=float,
        default=0.0,
        metavar="M",
        help="wall time of this whole call in minutes (default 0: none); --resume goes on",
    )
    ablation.set_defaults(handler=_ablation)


def _common(
    parser: argparse.ArgumentParser,
    robot_source: Callable[[argparse.ArgumentParser], None],
    priors: bool = True,
    required: bool = True,
) -> None:
    # `train` checks --config and --out itself, so that `train ablation --config ...` parses
    parser.add_argument(
        "--config",
        type=recipe_argument("train"),
        required=required,
        help="recipe: a TOML file or a built-in name (required)",
    )
    parser.add_argument("--out", type=Path, required=required, help="output folder (required)")
    if priors:
        parser.add_argument(
            "--priors",
            metavar=PRIOR_CHOICES,
            help="comma-separated [priors.*] names to use, or 'none' (default: all in the config)",
        )
    parser.add_argument("--iterations", type=int, help="override [run] iterations")
    parser.add_argument("--seed", type=int, help="override [run] seed")
    parser.add_argument(
        "--devices",
        type=_devices,
        metavar="N|all",
        help="override [run] devices: local devices to split the environments over (default 1)",
    )
    robot_source(parser)


def _devices(text: str) -> int | str:
    """`--devices` as a count or 'all'."""
    if text == "all":
        return text
    try:
        count = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r}: expected a count or 'all'") from None
    if count < 0:
        raise argparse.ArgumentTypeError(f"{count}: expected a count >= 0 (0: all)")
    return count


def parse_priors(text: str | None, available: list[str]) -> list[str]:
    """`--priors` as a list of names ('none' -> [], None -> every prior of the config)."""
    if text is None:
        return list(available)
    names = [n.strip() for n in text.split(",") if n.strip()]
    if names == ["none"]:
        return []
    if not names or "none" in names:
        raise TrainError(f"--priors {text!r}: expected {PRIOR_CHOICES}")
    return names


def _config(args: argparse.Namespace):  # -> TrainConfig
    from motionkit.train.config import RunConfig, TrainConfig

    config = TrainConfig.from_toml(args.config)
    run: RunConfig = config.run
    if args.iterations is not None:
        if args.iterations < 1:
            raise TrainError(f"--iterations {args.iterations}: at least 1")
        run = replace(run, iterations=args.iterations)
    if args.seed is not None:
        run = replace(run, seed=args.seed)
    if args.devices is not None:
        run = replace(run, devices=args.devices)
    return replace(config, run=run)


def _train(args: argparse.Namespace) -> int:
    if args.config is None or args.out is None:
        raise TrainError("train needs --config TOML and --out DIR (see motionkit train --help)")
    require_train_extra()
    from motionkit.train.runner import OUTPUTS, train

    config = _config(args)
    config = config.select_priors(parse_priors(args.priors, list(config.priors)))
    robot = load_robot(args.urdf, args.spec)
    enable_compile_cache()
    resume = args.resume
    if args.jets_at_rest and args.resume_from is None and args.init_from is None:
        raise TrainError(
            "--jets-at-rest needs --resume-from CHECKPOINT (another run's) or --init-from POLICY"
        )
    init_from = None
    if args.init_from is not None:
        if resume or args.resume_from is not None:
            raise TrainError("--init-from starts a new run: drop --resume / --resume-from")
        from motionkit.train.policy import load_policy

        init_from = load_policy(args.init_from)
    if args.resume_from is not None:
        from motionkit.train.checkpoint import place_checkpoint

        check_out(args.out, OUTPUTS, TrainError)  # (before the copy: a foreign file refused)
        if place_checkpoint(args.out, args.resume_from, "--resume-from"):
            _print(f"copied {args.resume_from} to {args.out}")
        elif args.jets_at_rest:
            raise TrainError(
                f"--jets-at-rest: {args.resume_from} is the run's own checkpoint; its jets "
                "were set at rest when the run began (pass --resume)"
            )
        resume = True
    summary = train(
        config,
        args.out,
        robot,
        resume=resume,
        jets_at_rest=args.jets_at_rest,
        init_from=init_from,
        progress=_print,
    )
    print(f"wrote {args.out}: {summary['iterations']} iterations in {summary['seconds']:.0f} s")
    return 0


def _seeds(text: str) -> list[int]:
    """`--seeds` as a list of distinct seeds >= 0."""
    try:
        seeds = [int(part) for part in text.split(",") if part.strip()]
    except ValueError:
        seeds = []
    if not seeds or min(seeds) < 0 or len(set(seeds)) != len(seeds):
        raise argparse.ArgumentTypeError(f"{text!r}: expected distinct seeds >= 0, e.g. 0,1")
    return seeds


def _ablation(args: argparse.Namespace) -> int:
    require_train_extra()
    from motionkit.train.ablation import OUTPUTS, run_ablation

    if args.seeds is not None and args.seed is not None:
        raise TrainError("pass --seeds or --seed, not both")
    if args.max_minutes < 0:
        raise TrainError(f"--max-minutes {args.max_minutes}: expected >= 0 (0: no limit)")
    config = _config(args)
    robot = load_robot(args.urdf, args.spec)
    enable_compile_cache()
    result = run_ablation(
        config,
        args.out,
        robot,
        args.seeds,
        resume=args.resume,
        max_minutes=args.max_minutes,
        progress=_print,
    )
    print(result["table"], end="")
    written = [name for name in OUTPUTS if (args.out / name).is_file()]
    print(f"wrote {', '.join(written)} in {args.out}")
    return 0


def _export(args: argparse.Namespace) -> int:
    require_train_extra("train export")
    from motionkit.train.policy import export_policy

    robot = load_robot(args.urdf, args.spec)
    sizes = export_policy(args.run, args.out, robot, half=args.half, checkpoint=args.checkpoint)
    files = ", ".join(f"{name} {size / 1e3:.1f} kB" for name, size in sizes.items())
    print(f"wrote {args.out}: {files} ({sum(sizes.values()) / 1e6:.2f} MB)")
    return 0


def _evaluate(args: argparse.Namespace) -> int:
    require_train_extra("train evaluate")
    from motionkit.train.runner import evaluate_run

    robot = load_robot(args.urdf, args.spec)
    enable_compile_cache()
    if args.per_tile:
        from motionkit.train.terrain_eval import evaluate_tiles

        others = [args.terrain, args.prior, args.air_share, args.prior_starts or None]
        if any(value is not None for value in others) or args.noise:
            raise TrainError(
                "--per-tile evaluates every tile from standing without noise: drop "
                "--terrain, --prior, --prior-starts, --air-share and --noise"
            )

        evaluate_tiles(
            args.run,
            robot,
            robots=args.robots,
            course=args.seed or 0,
            checkpoint=args.checkpoint,
            stage=args.stage,
            progress=_print,
        )
        return 0
    figures = evaluate_run(
        args.run,
        robot,
        args.prior_starts,
        args.noise,
        args.checkpoint,
        args.seed,
        args.prior,
        args.air_share,
        args.stage,
        args.terrain,
    )
    for name, value in figures.items():
        print(f"{name.removeprefix('eval_')} {value:.6g}")
    return 0


def _curves(args: argparse.Namespace) -> int:
    from motionkit.train.curves import draw_curves

    print(f"wrote {draw_curves(args.run, args.out)}")
    return 0


def _print(line: str) -> None:
    print(line, flush=True)
