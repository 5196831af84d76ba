"""Fitting the LSTM thrust model: optax Adam on free-run windows (truncated BPTT), validation
free-runs on the held-back end of every log, early stopping on the validation RMSE."""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np
import optax

from motionkit.errors import JetIdentError
from motionkit.jet_ident.benchlog import BenchLog
from motionkit.jet_ident.config import ModelConfig, TrainConfig
from motionkit.jet_ident.model import Normalisation, init_variables, rollout
from motionkit.jet_ident.step import LSTMThrust, free_run_jit

Segment = tuple[np.ndarray, np.ndarray]  # (thrust [N], throttle [%]) of consecutive samples


@dataclass
class TrainResult:
    params: LSTMThrust  # the best model (lowest validation RMSE)
    best_step: int
    stopped: str  # why training ended: "early stop", "max steps" or "time limit"
    seconds: float
    history: list[dict[str, float]] = field(default_factory=list)


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


def split(logs: Sequence[BenchLog], fraction: float) -> tuple[list[Segment], list[Segment]]:
    """Training and validation segments: the last `fraction` of every log validates."""
    train, valid = [], []
    for log in logs:
        cut = round(log.samples * (1 - fraction))
        train.append((log.thrust[:cut], log.throttle[:cut]))
        valid.append((log.thrust[cut:], log.throttle[cut:]))
    return train, valid


def train_lstm(
    logs: Sequence[BenchLog],
    model: ModelConfig,
    config: TrainConfig,
    progress: Callable[[str], None] | None = None,
) -> TrainResult:
    """Fit the LSTM to `logs`; `progress` receives one line per validation."""
    start = time.perf_counter()
    dt = common_dt(logs)
    train, valid = split(logs, config.validation_fraction)
    length = config.warmup + config.window
    for log, (thrust, _), (v_thrust, _) in zip(logs, train, valid, strict=True):
        if len(thrust) < length or len(v_thrust) < 2 * config.warmup:
            raise JetIdentError(
                f"{log.name}: {log.samples} samples are too few for windows of {length} and a "
                f"validation part of at least {2 * config.warmup}"
            )
    norm = Normalisation.fit(
        np.concatenate([t for t, _ in train]), np.concatenate([u for _, u in train])
    )
    hidden, warmup = model.hidden, config.warmup
    schedule = optax.cosine_decay_schedule(config.learning_rate, config.max_steps, alpha=0.05)
    optimizer = optax.chain(optax.clip_by_global_norm(config.clip_norm), optax.adam(schedule))

    def loss_fn(variables: dict[str, Any], thrust: jax.Array, throttle: jax.Array) -> jax.Array:
        simulated = rollout(hidden, variables, norm, dt, thrust, throttle, warmup)
        return jnp.mean(((simulated - thrust[:, warmup:]) / norm.thrust_std) ** 2)

    @jax.jit
    def update(variables: Any, opt_state: Any, thrust: jax.Array, throttle: jax.Array) -> Any:
        loss, grads = jax.value_and_grad(loss_fn)(variables, thrust, throttle)
        updates, opt_state = optimizer.update(grads, opt_state, variables)
        return optax.apply_updates(variables, updates), opt_state, loss

    rng = np.random.default_rng(config.seed)
    starts = np.array([len(t) - length + 1 for t, _ in train], dtype=float)
    variables = init_variables(hidden, config.seed)
    opt_state = optimizer.init(variables)
    best = (np.inf, variables, 0)
    history: list[dict[str, float]] = []
    losses: list[float] = []
    stopped, waited = "max steps", 0
    for step in range(1, config.max_steps + 1):
        which = rng.choice(len(train), size=config.batch, p=starts / starts.sum())
        offsets = (rng.random(config.batch) * starts[which]).astype(int)
        thrust = np.stack(
            [train[w][0][o : o + length] for w, o in zip(which, offsets, strict=True)]
        )
        throttle = np.stack(
            [train[w][1][o : o + length] for w, o in zip(which, offsets, strict=True)]
        )
        variables, opt_state, loss = update(variables, opt_state, thrust, throttle)
        losses.append(float(loss))
        if step % config.eval_every and step != config.max_steps:
            continue
        mae, rmse = validate(LSTMThrust.from_variables(variables, norm, dt), valid, warmup)
        elapsed = time.perf_counter() - start
        history.append(
            {
                "step": step,
                "loss": float(np.mean(losses)),
                "val_mae": mae,
                "val_rmse": rmse,
                "seconds": elapsed,
            }
        )
        losses = []
        if rmse < best[0]:
            best, waited = (rmse, variables, step), 0
        else:
            waited += 1
        if progress:
            mark = "*" if best[2] == step else " "
            progress(
                f"step {step:5d}  loss {history[-1]['loss']:.5f}  validation MAE {mae:6.3f} N"
                f"  RMSE {rmse:6.3f} N {mark} {elapsed:5.0f} s"
            )
        if waited >= config.patience:
            stopped = "early stop"
            break
        if elapsed > 60 * config.max_minutes:
            stopped = "time limit"
            break
    params = LSTMThrust.from_variables(best[1], norm, dt)
    return TrainResult(params, best[2], stopped, time.perf_counter() - start, history)


def validate(params: LSTMThrust, segments: Sequence[Segment], warmup: int) -> tuple[float, float]:
    """Free-run MAE and RMSE [N] over the segments (their first `warmup` samples excluded)."""
    errors = [
        np.asarray(free_run_jit(params, jnp.asarray(t), jnp.asarray(u), warmup)) - t[warmup:]
        for t, u in segments
    ]
    error = np.concatenate(errors)
    return float(np.mean(np.abs(error))), float(np.sqrt(np.mean(error**2)))
