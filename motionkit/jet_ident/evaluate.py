"""Free-run evaluation of thrust models against bench logs, the noise floor, and the plot.

Every model free-runs a whole log: the first `warmup` samples feed it the measured thrust (the
LSTM's state settles; the engine rests at idle there in identification runs), then it feeds on
its own output. Errors are simulated minus measured thrust over the free-run samples.

- MAE, RMSE, max: over all free-run samples [N].
- steady: mean |error of the mean| over the last second of every throttle hold of >= 4 s [N].
- rise: mean |simulated - measured| 63 % rise time after every throttle step of >= 15 % held
  >= 2 s (after >= 1 s at the previous level) [s]; each signal's own start and end levels.
- noise floor: the error of a perfect model, from the log alone: the load-cell noise sigma by
  the median absolute second difference (sigma = 1.4826 MAD / sqrt(6)); MAE = sigma sqrt(2/pi).
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Mapping, Sequence
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any, Protocol

import jax.numpy as jnp
import numpy as np

from motionkit.core.errors import JetIdentError
from motionkit.files.outputs import atomic_output
from motionkit.jet_ident.benchlog import BenchLog
from motionkit.jet_ident.step import LSTMThrust, free_run_jit

HOLD_S, STEP_PCT = 4.0, 15.0


class ThrustModel(Protocol):
    def free_run(
        self, thrust: np.ndarray, throttle: np.ndarray, warmup: int, dt: float
    ) -> np.ndarray: ...


class LSTMRunner:
    """The exported LSTM behind the baselines' free_run interface."""

    def __init__(self, params: LSTMThrust) -> None:
        self.params = params

    def free_run(
        self, thrust: np.ndarray, throttle: np.ndarray, warmup: int, dt: float
    ) -> np.ndarray:
        if abs(dt - self.params.dt) > 1e-6 * dt:
            raise JetIdentError(
                f"the log is sampled every {dt:g} s, the model every {self.params.dt:g} s"
            )
        simulated = free_run_jit(self.params, jnp.asarray(thrust), jnp.asarray(throttle), warmup)
        return np.asarray(simulated, dtype=np.float64)


@dataclass(frozen=True)
class Metrics:
    mae: float  # N
    rmse: float  # N
    max: float  # N
    steady: float  # N (nan without holds)
    rise: float  # s (nan without steps)
    holds: int
    steps: int
    samples: int

    def to_dict(self) -> dict[str, float]:
        return {
            k: (None if isinstance(v, float) and np.isnan(v) else v)
            for k, v in asdict(self).items()
        }


def noise_sigma(thrust: np.ndarray) -> float:
    d2 = np.diff(thrust, 2)
    return float(1.4826 * np.median(np.abs(d2 - np.median(d2))) / np.sqrt(6))


def noise_floor(logs: Sequence[BenchLog]) -> tuple[float, float]:
    """(MAE, RMSE) [N] a perfect model would score: pooled load-cell noise of the logs.

    Each log's noise sigma comes from the median absolute second difference of its thrust;
    the logs are pooled weighted by their samples (see the module doc).

    Args:
        logs: the bench logs (or their validation parts).

    Returns:
        (sigma sqrt(2/pi), sigma) [N]: the MAE and RMSE of white noise of that sigma.
    """
    weights = np.array([log.samples for log in logs], dtype=float)
    sigma = float(
        np.sqrt(np.average([noise_sigma(log.thrust) ** 2 for log in logs], weights=weights))
    )
    return sigma * float(np.sqrt(2 / np.pi)), sigma


def _runs(throttle: np.ndarray) -> list[tuple[int, int]]:
    """(start, end) of the runs of constant throttle."""
    edges = np.flatnonzero(np.diff(throttle) != 0) + 1
    bounds = np.concatenate([[0], edges, [len(throttle)]])
    return [(int(a), int(b)) for a, b in itertools.pairwise(bounds)]


def _rise_time(signal: np.ndarray, k: int, end: int, before: int, dt: float) -> float:
    smooth = np.convolve(signal, np.ones(5) / 5, mode="same")
    start_level = signal[k - before : k].mean()
    end_level = signal[end - round(0.3 / dt) : end].mean()
    level = start_level + 0.63 * (end_level - start_level)
    above = (smooth[k:end] - level) * np.sign(end_level - start_level) >= 0
    return float(np.argmax(above) * dt) if above.any() else float("nan")


def metrics(
    measured: np.ndarray, simulated: np.ndarray, throttle: np.ndarray, warmup: int, dt: float
) -> Metrics:
    """Metrics of one free-run (`simulated` holds samples warmup..n-1 of the log)."""
    error = simulated - measured[warmup:]
    full = np.concatenate([measured[:warmup], simulated])
    steady, rise = [], []
    runs = _runs(throttle)
    for i, (a, b) in enumerate(runs):
        if b - round(1 / dt) >= warmup and (b - a) * dt >= HOLD_S:
            window = slice(b - round(1 / dt), b)
            steady.append(full[window].mean() - measured[window].mean())
        if i == 0 or (b - a) * dt < 2.0 or a - warmup < round(1 / dt):
            continue
        pa, pb = runs[i - 1]
        if (pb - pa) * dt >= 1.0 and abs(throttle[a] - throttle[a - 1]) >= STEP_PCT:
            before = round(0.5 / dt)
            times = [_rise_time(s, a, b, before, dt) for s in (measured, full)]
            rise.append(times[1] - times[0])
    return Metrics(
        float(np.mean(np.abs(error))),
        float(np.sqrt(np.mean(error**2))),
        float(np.max(np.abs(error))),
        float(np.mean(np.abs(steady))) if steady else float("nan"),
        float(np.nanmean(np.abs(rise))) if rise and not np.all(np.isnan(rise)) else float("nan"),
        len(steady),
        len(rise),
        len(error),
    )


def evaluate(
    models: Mapping[str, ThrustModel], logs: Sequence[BenchLog], warmup: int
) -> tuple[dict[str, Metrics], dict[str, list[np.ndarray]]]:
    """Metrics of every model over all logs pooled, and the free-runs (per model, per log)."""
    runs: dict[str, list[np.ndarray]] = {name: [] for name in models}
    for log in logs:
        if log.samples <= 2 * warmup:
            raise JetIdentError(
                f"{log.name}: {log.samples} samples; evaluation needs > {2 * warmup}"
            )
        for name, model in models.items():
            runs[name].append(model.free_run(log.thrust, log.throttle, warmup, log.dt))
        first = next(iter(models))
        check_thrust_scale(log, runs[first][-1], warmup, first)
    results = {}
    for name in models:
        parts = [
            metrics(log.thrust, sim, log.throttle, warmup, log.dt)
            for log, sim in zip(logs, runs[name], strict=True)
        ]
        results[name] = _pool(parts)
    return results, runs


SCALE_TOLERANCE = 3.0  # a log's mean thrust within 1/3-3x of the model's: the same unit


def check_thrust_scale(log: BenchLog, simulated: np.ndarray, warmup: int, model: str) -> None:
    """A JetIdentError when the log's thrust is on another scale than the model's free run on
    its throttle (`simulated`: samples warmup..n-1): a column in kN or grams, or a log of
    another engine, whose errors would say nothing about the model."""
    measured = float(np.mean(log.thrust[warmup:]))
    predicted = float(np.mean(simulated))
    ratio = measured / predicted if predicted > 0 else math.inf
    if not 1 / SCALE_TOLERANCE <= ratio <= SCALE_TOLERANCE:
        raise JetIdentError(
            f"{log.name}: thrust_n averages {measured:.4g} N where the {model} model gives "
            f"{predicted:.4g} N for the same throttle ({ratio:.3g}x): is the column in another "
            "unit (kN, grams) or the log of another engine? expected newtons"
        )


def _pool(parts: Sequence[Metrics]) -> Metrics:
    n = np.array([p.samples for p in parts], dtype=float)

    def weighted(values: list[float], weights: list[float]) -> float:
        pairs = [(v, w) for v, w in zip(values, weights, strict=True) if w > 0 and not np.isnan(v)]
        if not pairs:
            return float("nan")
        kept, weight = zip(*pairs, strict=True)
        return float(np.average(kept, weights=weight))

    return Metrics(
        float(np.average([p.mae for p in parts], weights=n)),
        float(np.sqrt(np.average([p.rmse**2 for p in parts], weights=n))),
        max(p.max for p in parts),
        weighted([p.steady for p in parts], [p.holds for p in parts]),
        weighted([p.rise for p in parts], [p.steps for p in parts]),
        sum(p.holds for p in parts),
        sum(p.steps for p in parts),
        int(n.sum()),
    )


def report_table(results: Mapping[str, Metrics], floor: tuple[float, float]) -> str:
    """The side-by-side table of `results` with the noise floor."""
    lines = [f"{'model':<18}{'MAE N':>8}{'RMSE N':>8}{'max N':>8}{'steady N':>10}{'rise s':>8}"]
    for name, m in results.items():
        lines.append(
            f"{name:<18}{m.mae:8.3f}{m.rmse:8.3f}{m.max:8.2f}{m.steady:10.3f}{m.rise:8.3f}"
        )
    lines.append(f"{'noise floor':<18}{floor[0]:8.3f}{floor[1]:8.3f}")
    any_m = next(iter(results.values()))
    lines.append(f"({any_m.samples} free-run samples, {any_m.holds} holds, {any_m.steps} steps)")
    return "\n".join(lines)


def require_matplotlib() -> None:
    """JetIdentError unless matplotlib can be imported (the plot needs it)."""
    try:
        import matplotlib  # noqa: F401
    except ImportError as exc:
        raise JetIdentError("the plot needs matplotlib: pip install matplotlib") from exc


def plot(path: Path, log: BenchLog, runs: Mapping[str, np.ndarray], warmup: int) -> None:
    """PNG of measured against simulated thrust over one log, with the throttle and the errors."""
    require_matplotlib()
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    t = log.time[warmup:]
    figure, (top, bottom) = plt.subplots(2, 1, figsize=(12, 6.5), sharex=True, height_ratios=[3, 1])
    top.plot(t, log.thrust[warmup:], color="0.6", lw=0.8, label="measured (load cell)")
    for i, (name, simulated) in enumerate(runs.items()):  # the first model drawn on top
        depth = 3 if i == 0 else 2
        top.plot(t, simulated, lw=1.0, label=f"{name} (free run)", zorder=depth)
        bottom.plot(t, simulated - log.thrust[warmup:], lw=0.6, label=name, zorder=depth)
    throttle_axis = top.twinx()
    throttle_axis.plot(t, log.throttle[warmup:], color="k", lw=0.5, ls=":", label="throttle")
    throttle_axis.set_ylabel("throttle [%]")
    top.set_ylabel("thrust [N]")
    top.set_title(f"{log.name}: measured and simulated thrust")
    top.legend(loc="upper left", fontsize=8)
    bottom.set_ylabel("error [N]")
    bottom.set_xlabel("time [s]")
    bottom.axhline(0, color="k", lw=0.5)
    figure.tight_layout()
    with atomic_output(Path(path)) as stream:
        figure.savefig(stream, format="png", dpi=110)
    plt.close(figure)


def plot_models(path: Path, log: BenchLog, models: Mapping[str, Any], warmup: int) -> None:
    """Free-run every model over `log` and plot them (`plot`); JetIdentError where the plot
    cannot be drawn (no matplotlib)."""
    runs = {
        name: model.free_run(log.thrust, log.throttle, warmup, log.dt)
        for name, model in models.items()
    }
    plot(path, log, runs, warmup)
