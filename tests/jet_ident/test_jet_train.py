"""A tiny training run lowers the free-run error; input checks."""

from dataclasses import replace

import numpy as np
import pytest

from motionkit.errors import JetIdentError
from motionkit.jet_ident.benchlog import BenchLog
from motionkit.jet_ident.config import BenchConfig, ModelConfig, TrainConfig
from motionkit.jet_ident.model import init_variables
from motionkit.jet_ident.step import LSTMThrust
from motionkit.jet_ident.synthetic import synthetic_run
from motionkit.jet_ident.train import split, train_lstm, validate

TINY = TrainConfig(
    warmup=10, window=60, batch=8, learning_rate=1e-2, max_steps=150, eval_every=50, patience=5
)


def test_tiny_training_reduces_the_free_run_error() -> None:
    bench = BenchConfig(duration_s=90.0)
    logs = [synthetic_run(bench, seed).log for seed in (1, 2)]
    lines: list[str] = []
    result = train_lstm(logs, ModelConfig(hidden=8), TINY, lines.append)
    _, valid = split(logs, TINY.validation_fraction)
    # The starting point: the initial weights with the normalisation training used.
    untrained = LSTMThrust.from_variables(init_variables(8, TINY.seed), result.params.norm, 0.01)
    before = validate(untrained, valid, TINY.warmup)
    after = validate(result.params, valid, TINY.warmup)
    assert after[1] < 0.6 * before[1], (before, after)
    assert after[1] == pytest.approx(min(h["val_rmse"] for h in result.history), rel=1e-4)
    assert len(lines) == len(result.history) == 3 and "validation MAE" in lines[0]
    assert result.history[-1]["loss"] < result.history[0]["loss"]
    assert result.stopped in ("max steps", "early stop")


def test_logs_must_share_the_rate_and_be_long_enough() -> None:
    t = np.arange(2000) * 0.01
    a = BenchLog(t, np.full_like(t, 50), np.full_like(t, 100), "a")
    b = BenchLog(t * 2, np.full_like(t, 50), np.full_like(t, 100), "b")
    with pytest.raises(JetIdentError, match="same rate"):
        train_lstm([a, b], ModelConfig(4), TINY)
    with pytest.raises(JetIdentError, match="too few"):
        train_lstm([a], ModelConfig(4), replace(TINY, window=5000))
    with pytest.raises(JetIdentError, match="no bench logs"):
        train_lstm([], ModelConfig(4), TINY)
