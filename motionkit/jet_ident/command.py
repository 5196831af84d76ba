"""`motionkit jet-ident simulate|fit|eval`: thin wrappers over motionkit.jet_ident."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

from motionkit.errors import JetIdentError
from motionkit.extras import require
from motionkit.jet_ident.benchlog import COLUMNS, read_log
from motionkit.jet_ident.config import JetIdentConfig
from motionkit.outputs import write_text_atomic
from motionkit.recipes import argument

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
        type=argument("jet_ident"),
        help="recipe: a TOML file or a built-in name (default: defaults)",
    )
    simulate.set_defaults(handler=_simulate)

    fit = commands.add_parser(
        "fit",
        help="fit the LSTM and the baselines to bench logs; write the model",
        description="Train the LSTM on the first part of every log (free-run windows, "
        "truncated BPTT, early stopping), fit the second-order grey-box and first-order lag "
        "baselines by least squares, and compare all three free-running on the last part "
        "(validation_fraction). Writes DIR/model.npz (LSTM, normalisation, dt, baselines, "
        "metadata), DIR/config.toml (resolved), DIR/report.json, DIR/report.txt, "
        "DIR/history.csv and DIR/validation.png (needs matplotlib).",
        epilog=EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    fit.add_argument("logs", nargs="+", type=Path, metavar="CSV", help="bench logs")
    fit.add_argument("--out", type=Path, required=True, help="output folder")
    fit.add_argument(
        "--config",
        type=argument("jet_ident"),
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
    fit_logs(args.logs, Path(args.out), _config(args.config))
    return 0


def fit_logs(paths: list[Path], out: Path, config: JetIdentConfig) -> dict[str, Any]:
    """Fit the LSTM and the baselines to the bench logs at `paths`, print the comparison and
    write OUT/model.npz, config.toml, report.json, report.txt, history.csv (and
    validation.png with matplotlib); returns the report."""
    from motionkit.jet_ident.evaluate import report_table
    from motionkit.jet_ident.export import baselines_metadata, save_model
    from motionkit.jet_ident.fit import identify, lstm_wins

    logs = [read_log(path) for path in paths]  # every log checked before the long part
    names = [log.name for log in logs]
    print(
        f"{len(logs)} log(s): "
        + ", ".join(f"{n} ({g.duration:.0f} s)" for n, g in zip(names, logs, strict=True))
    )
    result = identify(logs, config, lambda line: print(line, flush=True))
    table = report_table(result.metrics, result.floor)
    report: dict[str, Any] = {
        "logs": [str(p) for p in paths],
        "validation_fraction": config.train.validation_fraction,
        "warmup": config.train.warmup,
        "metrics": {name: m.to_dict() for name, m in result.metrics.items()},
        "noise_floor": {"mae": result.floor[0], "rmse": result.floor[1]},
        "lstm_beats_baselines": lstm_wins(result.metrics),
        "training": {
            "best_step": result.training.best_step,
            "stopped": result.training.stopped,
            "seconds": round(result.training.seconds, 2),
        },
        "baseline_smoothing_s": result.smoothing_s,
    }
    metadata = {
        "baselines": baselines_metadata(result.grey_box, result.first_order),
        "warmup": config.train.warmup,
        "config": config.to_dict(),
        "report": report,
    }
    save_model(out / "model.npz", result.training.params, metadata)
    write_text_atomic(out / "config.toml", config.to_toml())
    write_text_atomic(out / "report.json", json.dumps(report, indent=2) + "\n")
    title = f"validation (free run, last {config.train.validation_fraction:.0%} of each log)"
    write_text_atomic(out / "report.txt", f"{title}\n{table}\n")
    rows = ["step,loss,val_mae,val_rmse,seconds"]
    rows += [
        ",".join(f"{h[k]:g}" for k in ("step", "loss", "val_mae", "val_rmse", "seconds"))
        for h in result.training.history
    ]
    write_text_atomic(out / "history.csv", "\n".join(rows) + "\n")
    print(f"\n{title}")
    print(table)
    print(f"LSTM beats both baselines: {'yes' if report['lstm_beats_baselines'] else 'NO'}")
    _try_plot(out / "validation.png", result.validation[0], result.models(), config.train.warmup)
    print(f"wrote {out}/model.npz, config.toml, report.json, report.txt, history.csv")
    return report


def _eval(args: argparse.Namespace) -> int:
    _require_train_extra()
    from motionkit.jet_ident.evaluate import (
        LSTMRunner,
        evaluate,
        noise_floor,
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
        _try_plot(args.plot, logs[0], models, warmup, quiet=args.json)
    return 0


def _try_plot(
    path: Path, log: Any, models: dict[str, Any], warmup: int, quiet: bool = False
) -> None:
    from motionkit.jet_ident.evaluate import plot

    runs = {
        name: model.free_run(log.thrust, log.throttle, warmup, log.dt)
        for name, model in models.items()
    }
    try:
        plot(path, log, runs, warmup)
    except JetIdentError as exc:
        print(f"plot skipped: {exc}", file=sys.stderr)
        return
    if not quiet:
        print(f"wrote {path}")
