"""Fitting the LSTM thrust model: optax Adam on free-run windows (truncated BPTT), validation
free-runs on held-back blocks of every log, early stopping on the validation RMSE.

One log of an engine covers its operating range sparsely, so three things carry the fit to
states it has not seen: validation blocks spread over every log (the training windows come from
all of its parts); a physical prior under the LSTM (model.py), started from least squares on
the training part, fitted alone by its free run, then trained with the LSTM; and a dead time,
the throttle fed `delay` samples late (of 0 to `max_delay_s`, the one whose least-squares prior
free-runs best on validation). Each prior of `ModelConfig.priors` is trained in turn (a share
of the time left each); the one best on validation is kept.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from functools import partial
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np
import optax

from motionkit.core.errors import JetIdentError
from motionkit.jet_ident.baselines import fit_grey_box, smoothed
from motionkit.jet_ident.benchlog import BenchLog
from motionkit.jet_ident.config import ModelConfig, TrainConfig
from motionkit.jet_ident.model import Normalisation, first_order_terms, init_variables, rollout
from motionkit.jet_ident.step import LSTMThrust, free_run_jit
from motionkit.runtime.progress import Progress, silent

Segment = tuple[np.ndarray, np.ndarray]  # (thrust [N], throttle [%]) of consecutive samples
PRIOR_SMOOTHING_S = 0.5  # the derivative filter of the priors' least squares


@dataclass
class TrainResult:
    params: LSTMThrust  # the best model (lowest validation RMSE)
    best_step: int
    stopped: str  # why training ended: "early stop", "max steps" or "time limit"
    seconds: float
    history: list[dict[str, float]] = field(default_factory=list)
    prior: str = "none"  # the prior of the best model
    delay: int = 0  # its dead time [samples]
    mae: float = float("nan")  # its validation free-run MAE and RMSE [N]
    rmse: float = float("nan")
    scores: dict[str, tuple[float, float]] = field(default_factory=dict)  # per prior tried


@dataclass(frozen=True)
class PriorStart:
    """Where a prior's training starts: its least-squares coefficients (None: no prior), its
    dead time [samples] and the validation RMSE [N] of its free run."""

    coeffs: np.ndarray | None = None
    delay: int = 0
    rmse: float = float("inf")


@dataclass(frozen=True)
class Best:
    """The best model of a training run so far: its variables, the step it came at and its
    validation free-run MAE and RMSE [N]."""

    variables: Any
    step: int
    mae: float
    rmse: float


def common_dt(logs: Sequence[BenchLog]) -> float:
    """The sample interval all `logs` share, or JetIdentError."""
    if not logs:
        raise JetIdentError("no bench logs given")
    dts = [log.dt for log in logs]
    for log, dt in zip(logs, dts, strict=True):
        if abs(dt - dts[0]) > 1e-6 * dts[0]:
            raise JetIdentError(
                f"{log.name}: sampled every {dt:g} s, {logs[0].name} every {dts[0]:g} s; "
                "all logs of one fit need the same rate"
            )
    return dts[0]


def split_logs(
    logs: Sequence[BenchLog], fraction: float, blocks: int
) -> tuple[list[BenchLog], list[BenchLog]]:
    """Training and validation parts: every log cut into `blocks` equal sections, the last
    `fraction` of each validating (blocks = 1: the end of every log)."""
    train, valid = [], []
    for log in logs:
        edges = np.linspace(0, log.samples, blocks + 1).round().astype(int)
        for b in range(blocks):
            cut = edges[b + 1] - round((edges[b + 1] - edges[b]) * fraction)
            where = f" {b + 1}/{blocks}" if blocks > 1 else ""
            for part, s, out in (
                ("train", slice(edges[b], cut), train),
                ("validation", slice(cut, edges[b + 1]), valid),
            ):
                name = f"{log.name}[{part}{where}]"
                out.append(
                    BenchLog(log.time[s], log.throttle[s], log.thrust[s], name, log.metadata)
                )
    return train, valid


def split(
    logs: Sequence[BenchLog], fraction: float, blocks: int = 1
) -> tuple[list[Segment], list[Segment]]:
    """`split_logs` as (thrust, throttle) segments."""
    train, valid = split_logs(logs, fraction, blocks)
    return [(p.thrust, p.throttle) for p in train], [(p.thrust, p.throttle) for p in valid]


def prior_coeffs(kind: str, train: Sequence[BenchLog], norm: Normalisation) -> np.ndarray | None:
    """Least-squares start of a prior (model.py) on the training parts."""
    if kind == "none":
        return None
    if kind == "second_order":
        return np.array(fit_grey_box(train, PRIOR_SMOOTHING_S).coeffs)
    rows, targets = [], []
    for log in train:
        thrust, rate, _ = smoothed(log.thrust, log.dt, PRIOR_SMOOTHING_S)
        x = np.asarray(norm.inputs(thrust, log.throttle))
        rows.append(np.stack(first_order_terms(x), axis=1))
        targets.append(rate / norm.rate_scale)
    coeffs, *_ = np.linalg.lstsq(np.concatenate(rows), np.concatenate(targets), rcond=None)
    return coeffs


def late(throttle: np.ndarray, delay: int) -> np.ndarray:
    """The throttle `delay` samples late (its first value held before the log)."""
    return np.concatenate([np.full(delay, throttle[0]), throttle[: len(throttle) - delay]])


def prior_only(coeffs: np.ndarray, norm: Normalisation, dt: float) -> LSTMThrust:
    """The prior alone: an LSTM whose output is zero."""
    zero = jnp.zeros
    return LSTMThrust(zero((2, 4)), zero((1, 4)), zero(4), zero(1), zero(()), norm, dt, coeffs)


def prior_start(
    kind: str,
    train: Sequence[BenchLog],
    valid: Sequence[BenchLog],
    norm: Normalisation,
    warmup: int,
    max_delay: int,
) -> PriorStart:
    """The prior's least-squares coefficients and dead time: of 0..max_delay, the one whose
    prior free-runs best on the validation parts (the first of equals)."""
    if kind == "none":
        return PriorStart()
    starts = []
    for delay in range(max_delay + 1):
        shifted = [replace(p, throttle=late(p.throttle, delay)) for p in train]
        coeffs = prior_coeffs(kind, shifted, norm)
        checks = [(p.thrust, late(p.throttle, delay)) for p in valid]
        _, rmse = validate(prior_only(coeffs, norm, train[0].dt), checks, warmup)
        starts.append(PriorStart(coeffs, delay, rmse))
    return min(starts, key=lambda start: start.rmse)


def train_lstm(
    logs: Sequence[BenchLog],
    model: ModelConfig,
    config: TrainConfig,
    progress: Progress = silent,
) -> TrainResult:
    """Fit the LSTM to `logs` on each prior of `model.priors` in turn; keep the best.

    The best is the one of lowest validation free-run RMSE; each prior gets a share of the
    time left. `progress` receives one line per validation.

    Args:
        logs: the bench logs, all at the same sample rate; each is split into training and
            validation blocks (`config.validation_fraction`, `config.validation_blocks`).
        model: the LSTM's size, the priors to try and the longest dead time [s].
        config: the optimiser, windows [samples], validation, early stopping, time limit
            [min] and seed.
        progress: called with each line of progress.

    Returns:
        The TrainResult of the best prior: its model (LSTMThrust), best step, why it stopped,
        seconds, validation history, prior, dead time [samples], validation MAE and RMSE [N],
        and each prior's (MAE, RMSE) [N].

    Raises:
        JetIdentError: no logs, logs at different sample rates, or a training or validation
            part too short for the windows.
    """
    start = time.perf_counter()
    dt = common_dt(logs)
    train, valid = split_logs(logs, config.validation_fraction, config.validation_blocks)
    length = config.warmup + config.window
    short = [p for p in train if p.samples < length]
    short += [p for p in valid if p.samples < 2 * config.warmup]
    if short:
        raise JetIdentError(
            f"{short[0].name}: {short[0].samples} samples are too few for windows of {length} "
            f"and validation parts of at least {2 * config.warmup}"
        )
    norm = Normalisation.fit(
        np.concatenate([p.thrust for p in train]), np.concatenate([p.throttle for p in train])
    )
    checks = [(p.thrust, p.throttle) for p in valid]
    max_delay = round(model.max_delay_s / dt)
    runs = []
    for i, kind in enumerate(model.priors):
        prior = prior_start(kind, train, valid, norm, config.warmup, max_delay)
        segments = [(p.thrust, late(p.throttle, prior.delay)) for p in train]
        left = config.max_minutes - (time.perf_counter() - start) / 60
        minutes = left / (len(model.priors) - i)
        run = _train(segments, checks, norm, dt, prior, model.hidden, config, minutes, progress)
        run.prior, run.delay = kind, prior.delay
        runs.append(run)
        progress(
            f"{kind} prior, dead time {prior.delay} samples: validation RMSE {run.rmse:.3f} N "
            f"at step {run.best_step}"
        )
    best = min(runs, key=lambda r: r.rmse)
    best.scores = {r.prior: (r.mae, r.rmse) for r in runs}
    best.seconds = time.perf_counter() - start
    return best


def _train(
    train: Sequence[Segment],
    valid: Sequence[Segment],
    norm: Normalisation,
    dt: float,
    start_prior: PriorStart,
    hidden: int,
    config: TrainConfig,
    minutes: float,
    progress: Progress,
) -> TrainResult:
    """Adam on free-run windows of `config.window` samples, then (with `long_window`) on
    windows of that length, from the best so far, as many samples per step. With a prior, these
    two phases run first on the prior alone (the LSTM silent), then again on both. Each phase
    stops early on its own; the time limit ends them all."""
    start = time.perf_counter()
    prior, delay = start_prior.coeffs, start_prior.delay
    warmup = config.warmup
    windows = [(config.window, config.batch)]
    long_window = min(config.long_window, min(len(t) for t, _ in train) - warmup)
    if long_window > config.window:  # as long as the shortest training part allows
        windows.append((long_window, max(1, round(config.batch * config.window / long_window))))
    # with a prior: the prior alone first (the LSTM silent), then both together
    stages = (True, False) if prior is not None else (False,)
    phases = [(window, batch, alone) for alone in stages for window, batch in windows]

    def loss_fn(variables: dict[str, Any], thrust: jax.Array, throttle: jax.Array) -> jax.Array:
        simulated = rollout(hidden, variables, norm, dt, thrust, throttle, warmup)
        return jnp.mean(((simulated - thrust[:, warmup:]) / norm.thrust_std) ** 2)

    def score(variables: dict[str, Any]) -> tuple[float, float]:
        return validate(LSTMThrust.from_variables(variables, norm, dt, delay), valid, warmup)

    variables = init_variables(hidden, config.seed, prior)
    mae, rmse = score(variables)
    best = Best(variables, 0, mae, rmse)
    history: list[dict[str, float]] = [
        {"step": 0, "loss": float("nan"), "val_mae": mae, "val_rmse": rmse, "seconds": 0.0}
    ]
    schedule = optax.cosine_decay_schedule(config.learning_rate, config.max_steps, alpha=0.05)
    optimizer = optax.chain(optax.clip_by_global_norm(config.clip_norm), optax.adam(schedule))

    @partial(jax.jit, static_argnames="prior_alone")
    def update(
        variables: Any, opt_state: Any, thrust: jax.Array, throttle: jax.Array, prior_alone: bool
    ) -> Any:
        loss, grads = jax.value_and_grad(loss_fn)(variables, thrust, throttle)
        updates, opt_state = optimizer.update(grads, opt_state, variables)
        if prior_alone:  # the LSTM stays as it started: silent
            updates = {**updates, "params": jax.tree.map(jnp.zeros_like, updates["params"])}
        return optax.apply_updates(variables, updates), opt_state, loss

    step, stopped = 0, ""
    for window, batch, prior_alone in phases:  # each from the best so far, a fresh optimiser
        draw = WindowSampler(train, warmup + window, config.seed + step)
        variables = best.variables
        opt_state = optimizer.init(variables)
        losses: list[float] = []
        waited, first, stopped = 0, step + 1, "max steps"
        for step in range(first, first + config.max_steps):
            variables, opt_state, loss = update(variables, opt_state, *draw(batch), prior_alone)
            losses.append(float(loss))
            if (step - first + 1) % config.eval_every and step != first + config.max_steps - 1:
                continue
            mae, rmse = score(variables)
            elapsed = time.perf_counter() - start
            row = {"step": step, "loss": float(np.mean(losses)), "val_mae": mae}
            history.append({**row, "val_rmse": rmse, "seconds": elapsed})
            losses = []
            if rmse < best.rmse:
                best, waited = Best(variables, step, mae, rmse), 0
            else:
                waited += 1
            mark = "*" if best.step == step else " "
            progress(
                f"step {step:5d}  window {window}{' (prior alone)' * prior_alone}  "
                f"loss {row['loss']:.5f}  validation MAE "
                f"{mae:6.3f} N  RMSE {rmse:6.3f} N {mark} {elapsed:5.0f} s"
            )
            if waited >= config.patience:
                stopped = "early stop"
                break
            if elapsed > 60 * minutes:
                stopped = "time limit"
                break
        if stopped == "time limit":
            break
    params = LSTMThrust.from_variables(best.variables, norm, dt, delay)
    seconds = time.perf_counter() - start
    return TrainResult(params, best.step, stopped, seconds, history, mae=best.mae, rmse=best.rmse)


class WindowSampler:
    """Random training windows of `length` samples, uniformly over the segments: (thrust,
    throttle), each [batch, length]."""

    def __init__(self, train: Sequence[Segment], length: int, seed: int) -> None:
        self.train, self.length = train, length
        self.rng = np.random.default_rng(seed)
        self.starts = np.array(  # (segment, offset) of every window
            [(i, o) for i, (t, _) in enumerate(train) for o in range(len(t) - length + 1)]
        )

    def __call__(self, batch: int) -> tuple[np.ndarray, np.ndarray]:
        picks = self.starts[self.rng.integers(0, len(self.starts), batch)]
        span = self.length
        thrust = np.stack([self.train[w][0][o : o + span] for w, o in picks])
        return thrust, np.stack([self.train[w][1][o : o + span] for w, o in picks])


def validate(params: LSTMThrust, segments: Sequence[Segment], warmup: int) -> tuple[float, float]:
    """Free-run MAE and RMSE [N] over the segments (their first `warmup` samples excluded);
    infinite for a model that diverges."""
    errors = [
        np.asarray(free_run_jit(params, jnp.asarray(t), jnp.asarray(u), warmup)) - t[warmup:]
        for t, u in segments
    ]
    error = np.concatenate(errors)
    scores = np.mean(np.abs(error)), np.sqrt(np.mean(error**2))
    return tuple(float(np.nan_to_num(x, nan=np.inf)) for x in scores)  # type: ignore[return-value]
