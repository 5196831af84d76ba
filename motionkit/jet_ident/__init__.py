"""Jet thrust identification: bench logs, LSTM model, evaluation, export.

    log = read_log("bench.csv")                       # checked CSV (time_s, throttle_pct, thrust_n)
    run = synthetic_run(BenchConfig(), seed=1)        # a synthetic P250 bench log
    result = identify([log, ...], JetIdentConfig())   # LSTM + baselines, validation metrics
    report = fit_logs([path, ...], out, config)       # the same from CSV files, model and reports
    save_model("model.npz", result.training.params, metadata)
    params, metadata = load_model("model.npz")
    grey = load_jet("model.npz", "grey_box")           # or "lstm", "selected" (won validation)
    state = initial_state(params, thrust, throttle)
    state, thrust = thrust_next(params, state, thrust, throttle)   # pure JAX; jit and vmap
    ENGINES["spool"]                                  # a BenchConfig of the engine family

The names that need JAX (the [train] extra) are imported on first use, so that reading logs
and configs works without it; without JAX they are a JetIdentError naming the extra.
"""

from __future__ import annotations

import importlib
from typing import Any

from motionkit.core.errors import JetIdentError
from motionkit.core.extras import require
from motionkit.jet_ident.benchlog import BenchLog, parse_log, read_log, write_log
from motionkit.jet_ident.config import BenchConfig, JetIdentConfig, ModelConfig, TrainConfig

_LAZY = {
    "P250_COEFFS": "p250",
    "thrust_acceleration": "p250",
    "synthetic_run": "synthetic",
    "identification_profile": "synthetic",
    "train_lstm": "train",
    "identify": "fit",
    "fit_logs": "fit",
    "fit_grey_box": "baselines",
    "fit_first_order": "baselines",
    "noise_floor": "evaluate",
    "save_model": "export",
    "load_model": "export",
    "load_jet": "export",
    "ENGINES": "family",
    "LSTMThrust": "step",
    "GreyBoxThrust": "step",
    "IdealThrust": "step",
    "initial_state": "step",
    "thrust_next": "step",
    "free_run": "step",
}

__all__ = [
    "BenchConfig",
    "BenchLog",
    "JetIdentConfig",
    "ModelConfig",
    "TrainConfig",
    "parse_log",
    "read_log",
    "write_log",
    *_LAZY,
]


def __getattr__(name: str) -> Any:
    if name in _LAZY:
        require("train", f"motionkit.jet_ident.{name}", JetIdentError, ("jax", "flax", "optax"))
        return getattr(importlib.import_module(f"motionkit.jet_ident.{_LAZY[name]}"), name)
    raise AttributeError(f"module 'motionkit.jet_ident' has no attribute {name!r}")
