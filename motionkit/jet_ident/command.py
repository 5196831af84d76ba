"""`motionkit jet-ident simulate|fit|eval`: thin wrappers over motionkit.jet_ident."""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from motionkit.cli import echo, recipe_argument
from motionkit.core.errors import JetIdentError
from motionkit.core.extras import require
from motionkit.files.outputs import check_out
from motionkit.jet_ident.benchlog import COLUMNS, read_log
from motionkit.jet_ident.config import JetIdentConfig

# The handlers import the JAX modules when they run: `motionkit` works without the extra.

EPILOG = f"""\
Bench logs are CSV files with a header naming the columns {", ".join(COLUMNS)}
(time [s], strictly increasing at a constant rate; throttle command [%], 0-100; load-cell
thrust [N]); lines starting with '#' are comments ('# key: value' is kept as metadata).
The model steps T[k+1] = T[k] + g(T[k], u[k]) dt with g an LSTM; 'free run' means the model
feeds on its own thrust after a short warm-up on the measured one (see --help of fit/eval).

Typical run (the recipe jet_ident/p250.toml):
  motionkit jet-ident simulate --seed 1 --out logs/p250_1.csv   (and seeds 2-5, 101)
  motionkit jet-ident fit logs/p250_[1-5].csv --out fits/p250 --config p250
  motionkit jet-ident eval fits/p250/model.npz logs/p250_101.csv"""


def add_commands(stages: argparse._SubParsersAction) -> None:
    jet = stages.add_parser(
        "jet-ident",
        help="identify jet-engine thrust models from bench logs (LSTM, JetCat P250)",
        description="Jet thrust identification: synthetic P250 bench logs, fitting the LSTM "
        "thrust model with two baselines, free-run evaluation and export for the simulator.",
        epilog=EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    commands = jet.add_subparsers(dest="jet_command", required=True, metavar="ACTION")

    simulate = commands.add_parser(
        "simulate",
        help="write a synthetic P250 bench log (CSV)",
        description="Run the published second-order P250 model on a seeded identification "
        "profile (steps, ramps, chirps around 10-90 % throttle) with the imperfections of a "
        "real bench (load-cell noise and low-pass, ambient temperature, throttle quantisation, "
        "delay); settings in the [bench] table of --config.",
        epilog=EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    simulate.add_argument("--out", type=Path, required=True, help="CSV file to write")
    simulate.add_argument("--seed", type=int, help="profile and noise seed (default: [bench] seed)")
    simulate.add_argument("--duration", type=float, help="seconds (default: [bench] duration_s)")
    simulate.add_argument(
        "--config",
        type=recipe_argument("jet_ident"),
        help="recipe: a TOML file or a built-in name (default: defaults)",
    )
    simulate.set_defaults(handler=_simulate)

    fit = commands.add_parser(
        "fit",
        help="fit the LSTM and the baselines to bench logs; write the model",
        description="Train the LSTM on its physical prior (the prior alone first, then both) "
        "on the training blocks of every log (free-run windows, truncated BPTT, early "
        "stopping), fit the second-order grey-box and first-order lag baselines by least "
        "squares, and compare all three free-running on the validation blocks "
        "(validation_fraction of each log, in validation_blocks spread over it). Writes "
        "DIR/model.npz (LSTM, normalisation, dt, baselines, "
        "metadata), DIR/config.toml (resolved), DIR/report.json, DIR/report.txt, "
        "DIR/history.csv and DIR/validation.png (needs matplotlib).",
        epilog=EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    fit.add_argument("logs", nargs="+", type=Path, metavar="CSV", help="bench logs")
    fit.add_argument("--out", type=Path, required=True, help="output folder")
    fit.add_argument(
        "--config",
        type=recipe_argument("jet_ident"),
        help="recipe: a TOML file or a built-in name, e.g. p250",
    )
    fit.set_defaults(handler=_fit)

    score = commands.add_parser(
        "eval",
        help="free-run a fitted model (and its baselines) on bench logs",
        description="Free-run the model and the baselines stored with it over every log "
        "(after a warm-up of --warmup samples fed the measured thrust) and print MAE, RMSE, "
        "max error, steady-state error, rise-time error and the noise floor of the logs.",
        epilog=EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    score.add_argument("model", type=Path, metavar="MODEL", help="model.npz written by fit")
    score.add_argument("logs", nargs="+", type=Path, metavar="CSV", help="bench logs")
    score.add_argument("--json", action="store_true", help="print JSON instead of a table")
    score.add_argument("--plot", type=Path, metavar="PNG", help="plot the first log to PNG")
    score.add_argument("--warmup", type=int, help="warm-up samples (default: the fit's)")
    score.set_defaults(handler=_eval)


def _require_train_extra() -> None:
    require("train", "jet-ident", JetIdentError, ("jax", "flax", "optax"))


def _config(path: Path | None) -> JetIdentConfig:
    return JetIdentConfig.from_toml(path) if path else JetIdentConfig()


def _simulate(args: argparse.Namespace) -> int:
    from dataclasses import replace

    _require_train_extra()
    from motionkit.jet_ident.benchlog import write_log
    from motionkit.jet_ident.evaluate import noise_floor
    from motionkit.jet_ident.synthetic import synthetic_run

    bench = _config(args.config).bench
    if args.duration is not None:
        if args.duration < 10:
            raise JetIdentError(f"--duration {args.duration:g}: at least 10 s")
        bench = replace(bench, duration_s=args.duration)
    seed = bench.seed if args.seed is None else args.seed
    if args.out.is_dir():
        raise JetIdentError(f"--out {args.out}: is a folder; give the CSV file to write")
    check_out(args.out.parent, [], JetIdentError)  # writable, before the simulation
    run = synthetic_run(bench, seed)
    write_log(args.out, run.log)
    log = run.log
    print(
        f"wrote {args.out}: {log.samples} samples at {1 / log.dt:g} Hz ({log.duration:.0f} s), "
        f"seed {seed}, ambient {run.ambient_c:.1f} degC, thrust {log.thrust.min():.1f}-"
        f"{log.thrust.max():.1f} N, noise floor MAE {noise_floor([log])[0]:.2f} N"
    )
    return 0


def _fit(args: argparse.Namespace) -> int:
    _require_train_extra()
    from motionkit.jet_ident.fit import fit_logs

    fit_logs(args.logs, Path(args.out), _config(args.config), progress=echo)
    return 0


def _eval(args: argparse.Namespace) -> int:
    _require_train_extra()
    from motionkit.jet_ident.evaluate import (
        LSTMRunner,
        evaluate,
        noise_floor,
        plot_models,
        report_table,
        require_matplotlib,
    )
    from motionkit.jet_ident.export import baselines_from_metadata, load_model

    if args.plot:
        require_matplotlib()  # before the work, not after
    params, metadata = load_model(args.model)
    warmup = args.warmup if args.warmup is not None else int(metadata.get("warmup", 50))
    if warmup < 1:
        raise JetIdentError(f"--warmup {warmup}: at least 1")
    logs = [read_log(path) for path in args.logs]
    models = {"LSTM": LSTMRunner(params), **baselines_from_metadata(metadata)}
    results, _ = evaluate(models, logs, warmup)
    floor = noise_floor(logs)
    if args.json:
        out = {
            "model": str(args.model),
            "logs": [str(p) for p in args.logs],
            "warmup": warmup,
            "metrics": {name: m.to_dict() for name, m in results.items()},
            "noise_floor": {"mae": floor[0], "rmse": floor[1]},
        }
        print(json.dumps(out, indent=2))
    else:
        print(f"free run over {len(logs)} log(s) after {warmup} warm-up samples")
        print(report_table(results, floor))
    if args.plot:
        plot_models(args.plot, logs[0], models, warmup)
        if not args.json:
            print(f"wrote {args.plot}")
    return 0
