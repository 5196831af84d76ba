"""The identification run: the LSTM and both baselines fitted to the same logs, all three
free-run on the held-back validation part of every log; `fit_logs` runs it on log files and
writes the model and its reports."""

from __future__ import annotations

import json
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from motionkit.core.errors import JetIdentError
from motionkit.files.outputs import check_out, claim_out, write_text_atomic
from motionkit.jet_ident.baselines import FirstOrderLag, GreyBox, fit_first_order, fit_grey_box
from motionkit.jet_ident.benchlog import BenchLog, read_log
from motionkit.jet_ident.config import JetIdentConfig
from motionkit.jet_ident.evaluate import (
    LSTMRunner,
    Metrics,
    evaluate,
    noise_floor,
    plot_models,
    report_table,
)
from motionkit.jet_ident.export import baselines_metadata, save_model, selected
from motionkit.jet_ident.train import TrainResult, split_logs, train_lstm
from motionkit.runtime.progress import Progress, silent

SMOOTHING_S = (0.3, 0.5, 0.7, 1.0)  # baseline derivative filters tried; validation picks one
LSTM, GREY_BOX, FIRST_ORDER = "LSTM", "grey-box 2nd order", "first-order lag"
OUTPUTS = ("model.npz", "config.toml", "report.json", "report.txt", "history.csv", "validation.png")


@dataclass
class Identification:
    training: TrainResult
    grey_box: GreyBox
    first_order: FirstOrderLag
    smoothing_s: float  # the baselines' filter width
    validation: list[BenchLog]
    metrics: dict[str, Metrics]  # on the validation parts
    floor: tuple[float, float]  # noise floor (MAE, RMSE) of the validation parts

    def models(self) -> dict[str, LSTMRunner | GreyBox | FirstOrderLag]:
        return {
            LSTM: LSTMRunner(self.training.params),
            GREY_BOX: self.grey_box,
            FIRST_ORDER: self.first_order,
        }


@dataclass(frozen=True)
class Baselines:
    """Both baselines fitted with one derivative filter, and their validation figures."""

    smoothing_s: float
    grey_box: GreyBox
    first_order: FirstOrderLag
    metrics: dict[str, Metrics]


def _fit_baselines(
    train: Sequence[BenchLog], validation: Sequence[BenchLog], warmup: int, smoothing_s: float
) -> Baselines:
    grey, lag = fit_grey_box(train, smoothing_s), fit_first_order(train, smoothing_s)
    metrics, _ = evaluate({GREY_BOX: grey, FIRST_ORDER: lag}, validation, warmup)
    return Baselines(smoothing_s, grey, lag, metrics)


def identify(
    logs: Sequence[BenchLog], config: JetIdentConfig, progress: Progress = silent
) -> Identification:
    """Fit the LSTM and both baselines to `logs`; score all three on validation.

    The LSTM (train.py) and the baselines (their filter width chosen by validation RMSE) are
    fitted on the training blocks of every log; all three free-run on its validation blocks.

    Args:
        logs: the bench logs, all at the same sample rate.
        config: the LSTM's model and training settings (its `train.validation_fraction`,
            `validation_blocks` and `warmup` [samples] also split and score the baselines).
        progress: called with each line of progress.

    Returns:
        The Identification: the LSTM's TrainResult, the grey box and first-order lag, the
        baselines' filter width [s], the validation parts, each model's validation Metrics
        (MAE, RMSE, max [N], steady [N], rise [s] ...) and the noise floor (MAE, RMSE) [N].

    Raises:
        JetIdentError: no logs, logs at different sample rates, logs too short for the
            training windows, or a first-order fit that is unstable.
    """
    fraction, warmup = config.train.validation_fraction, config.train.warmup
    train, validation = split_logs(logs, fraction, config.train.validation_blocks)
    progress(f"training the LSTM on {sum(t.samples for t in train)} samples of {len(logs)} log(s)")
    training = train_lstm(logs, config.model, config.train, progress)
    progress(
        f"LSTM: {training.prior} prior, best at step {training.best_step} ({training.stopped}, "
        f"{training.seconds:.0f} s)"
    )
    fits = [_fit_baselines(train, validation, warmup, s) for s in SMOOTHING_S]
    grey = min(fits, key=lambda fit: fit.metrics[GREY_BOX].rmse)
    lag = min(fits, key=lambda fit: fit.metrics[FIRST_ORDER].rmse)
    progress(
        f"baselines: filter {grey.smoothing_s:g} s (grey box), "
        f"{lag.smoothing_s:g} s (first-order lag)"
    )
    result = Identification(
        training,
        grey.grey_box,
        lag.first_order,
        grey.smoothing_s,
        validation,
        {},
        noise_floor(validation),
    )
    result.metrics, _ = evaluate(result.models(), validation, warmup)
    return result


def lstm_wins(metrics: dict[str, Metrics]) -> bool:
    """Whether the LSTM has the lowest MAE and RMSE of all models."""
    others = [m for name, m in metrics.items() if name != LSTM]
    return all(metrics[LSTM].mae < m.mae and metrics[LSTM].rmse < m.rmse for m in others)


def fit_logs(
    paths: list[Path], out: Path, config: JetIdentConfig, *, progress: Progress = silent
) -> dict[str, Any]:
    """Fit the LSTM and the baselines to the bench logs at `paths`; write the model and reports.

    Reports the training and the comparison to `progress` and writes OUT/model.npz,
    config.toml, report.json, report.txt, history.csv (and validation.png with matplotlib);
    returns the report.

    Args:
        paths: the bench logs' CSV files (see `read_log`).
        out: the output folder (OUT).
        config: the identification's settings (see `identify`).
        progress: called with each line of progress and the report's table.

    Returns:
        The report also written to report.json: the logs, validation_fraction, warmup, each
        model's validation metrics, noise_floor, lstm_beats_baselines, the training's figures,
        baseline_smoothing_s and the model selected for the simulator.

    Raises:
        JetIdentError: an `out` that cannot take the files (checked before the fit), a log
            that cannot be read or is invalid, or a fit that fails (see `identify`).
    """
    warmup = config.train.warmup
    out = check_out(Path(out), OUTPUTS, JetIdentError)  # before the long part, like the logs
    logs = [read_log(path) for path in paths]
    names = [log.name for log in logs]
    progress(
        f"{len(logs)} log(s): "
        + ", ".join(f"{n} ({g.duration:.0f} s)" for n, g in zip(names, logs, strict=True))
    )
    result = identify(logs, config, progress)
    table = report_table(result.metrics, result.floor)
    report: dict[str, Any] = {
        "logs": [_shown(Path(p), out) for p in paths],
        "validation_fraction": config.train.validation_fraction,
        "warmup": warmup,
        "metrics": {name: m.to_dict() for name, m in result.metrics.items()},
        "noise_floor": {"mae": result.floor[0], "rmse": result.floor[1]},
        "lstm_beats_baselines": lstm_wins(result.metrics),
        "training": {
            "best_step": result.training.best_step,
            "stopped": result.training.stopped,
            "seconds": round(result.training.seconds, 2),
            "prior": result.training.prior,
        },
        "baseline_smoothing_s": result.smoothing_s,
        "selected": selected(result.metrics),
    }
    metadata = {
        "baselines": baselines_metadata(result.grey_box, result.first_order),
        "selected": report["selected"],
        "warmup": warmup,
        "config": config.to_dict(),
        "report": report,
    }
    claim_out(out, OUTPUTS, JetIdentError)
    save_model(out / "model.npz", result.training.params, metadata)
    write_text_atomic(out / "config.toml", config.to_toml())
    write_text_atomic(out / "report.json", json.dumps(report, indent=2) + "\n")
    title = (
        f"validation (free run, {config.train.validation_fraction:.0%} of each log in "
        f"{config.train.validation_blocks} blocks)"
    )
    write_text_atomic(out / "report.txt", f"{title}\n{table}\n")
    rows = ["step,loss,val_mae,val_rmse,seconds"]
    rows += [
        ",".join(f"{h[k]:g}" for k in ("step", "loss", "val_mae", "val_rmse", "seconds"))
        for h in result.training.history
    ]
    write_text_atomic(out / "history.csv", "\n".join(rows) + "\n")
    progress(f"\n{title}")
    progress(table)
    progress(f"LSTM beats both baselines: {'yes' if report['lstm_beats_baselines'] else 'NO'}")
    progress(f"selected for the simulator (validation RMSE): {report['selected']}")
    try:
        plot_models(out / "validation.png", result.validation[0], result.models(), warmup)
        progress(f"wrote {out / 'validation.png'}")
    except JetIdentError as exc:  # no matplotlib
        progress(f"plot skipped: {exc}")
    progress(f"wrote {out}/model.npz, config.toml, report.json, report.txt, history.csv")
    return report


def _shown(log: Path, out: Path) -> str:
    """A log's path as the report gives it: relative to OUT when it lies there (the folder then
    stays valid where it is moved), else as given."""
    try:
        return str(log.resolve().relative_to(out.resolve()))
    except ValueError:
        return str(log)
