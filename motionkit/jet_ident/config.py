"""The jet-identification config: frozen dataclasses, defaults here, filled from TOML recipes.

A recipe has up to three tables, [bench] (the synthetic bench, with the engine's parameters in
[bench.p250], [bench.rate_form] or [bench.spool]), [model] and [train]; a key left out keeps its
default below.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from motionkit.core.checks import check, refusal
from motionkit.core.errors import JetIdentError
from motionkit.core.tomlfile import load, read_toml, to_toml
from motionkit.jet_ident.p250 import (
    P220_RATE_FORM,
    P250_COEFFS,
    RATE_FORM,
    SCALES,
    UNSCALED,
    rate_form_coeffs,
)

PLANTS = ("p250", "rate_form", "spool")
PRIORS = ("second_order", "first_order", "none")


@dataclass(frozen=True)
class P250Plant:
    """An engine of the published second-order structure (p250.py): its 13 coefficients and
    its normalisation (thrust offset and scale [N], throttle offset and scale [%])."""

    coeffs: tuple[float, ...] = tuple(float(c) for c in P250_COEFFS)
    scales: tuple[float, float, float, float] = SCALES

    def __post_init__(self) -> None:
        check(self, JetIdentError, "finite", "coeffs", "scales")
        if len(self.coeffs) != 13:
            raise refusal(JetIdentError, "coeffs", "13 numbers (c0..c12)", self.coeffs)
        if self.scales[1] <= 0 or self.scales[3] <= 0:
            raise refusal(
                JetIdentError, "scales", "positive thrust and throttle scales", self.scales
            )


@dataclass(frozen=True)
class RateFormPlant:
    """An engine of the structure published for the P100/P220 (p250.py, RATE_FORM): K_T, K_TT,
    K_D, K_DD, K_TD, B_U, B_T, B_D, B_UU, c for thrust in N and throttle in %; by default a
    P220's."""

    coefficients: tuple[float, ...] = P220_RATE_FORM

    def __post_init__(self) -> None:
        check(self, JetIdentError, "finite", "coefficients")
        if len(self.coefficients) != len(RATE_FORM):
            raise refusal(
                JetIdentError,
                "coefficients",
                f"10 numbers ({', '.join(RATE_FORM)})",
                self.coefficients,
            )


@dataclass(frozen=True)
class SpoolPlant:
    """An engine of the spool structure (spool.py)."""

    max_thrust_n: float = 230.0  # thrust at full speed
    idle_speed: float = 0.3  # fraction of full speed at 0 % throttle
    thrust_exponent: float = 2.5  # T = max_thrust n^e
    time_constant_s: float = 0.25  # of the rotor at full speed (tau_full / n below)
    accel_limit: tuple[float, float] = (0.5, 1.0)  # ECU limits on speed up, down [1/s]
    fuel_lag_s: float = 0.0  # fuel metering lag (0: a first-order engine)

    def __post_init__(self) -> None:
        check(self, JetIdentError, "> 0", "max_thrust_n", "thrust_exponent", "time_constant_s")
        check(self, JetIdentError, "> 0", "accel_limit")
        check(self, JetIdentError, "in (0, 1)", "idle_speed")
        check(self, JetIdentError, ">= 0", "fuel_lag_s")


@dataclass(frozen=True)
class BenchConfig:
    """The synthetic bench (see synthetic.py for what each imperfection does) and its engine:
    `plant` names the structure, whose table holds the parameters."""

    # "p250": the published second-order P250 model; "rate_form": the structure published for
    # the P100/P220; "spool": spool.py
    plant: str = "p250"
    p250: P250Plant = P250Plant()
    rate_form: RateFormPlant = RateFormPlant()
    spool: SpoolPlant = SpoolPlant()
    duration_s: float = 540.0  # one identification run (the published profile: ~9 minutes)
    rate_hz: float = 100.0  # log rate of the public P250 identification logs
    substeps: int = 10  # RK4 steps per sample for the engine model
    noise_std_n: float = 1.5  # load-cell noise (white, Gaussian) [N]
    sensor_cutoff_hz: float = 5.0  # first-order low-pass of the load cell and its amplifier
    delay_s: float = 0.03  # command to engine (ECU) delay, rounded to whole samples
    throttle_step_pct: float = 0.5  # the ECU's throttle resolution
    ambient_c: tuple[float, float] = (15.0, 25.0)  # per-log ambient temperature range [degC]
    ambient_drift_c: float = 1.5  # the bench warms by this much over one log [degC]
    reference_c: float = 15.0  # ambient of the published model (gain 1)
    seed: int = 0  # `jet-ident simulate` default
    train_seeds: tuple[int, ...] = (1, 2, 3, 4, 5)  # the recipe's training logs (benchmark)
    heldout_seeds: tuple[int, ...] = (
        101,
        102,
        103,
        104,
    )  # held-out profiles never used in training

    def second_order(self) -> tuple[np.ndarray, tuple[float, ...]]:
        """The coefficients and normalisation of a second-order plant in p250.py's structure."""
        if self.plant == "rate_form":
            return rate_form_coeffs(self.rate_form.coefficients), UNSCALED
        return np.array(self.p250.coeffs), self.p250.scales

    def ideal(self) -> BenchConfig:
        """The same bench without its imperfections: no noise, sensor lag, delay, throttle
        quantisation or temperature effect (the published model alone)."""
        return replace(
            self,
            noise_std_n=0.0,
            sensor_cutoff_hz=1e4,
            delay_s=0.0,
            throttle_step_pct=0.0,
            ambient_c=(15.0, 15.0),
            ambient_drift_c=0.0,
        )

    def __post_init__(self) -> None:
        check(self, JetIdentError, PLANTS, "plant")
        check(self, JetIdentError, "> 0", "duration_s", "rate_hz", "sensor_cutoff_hz")
        check(self, JetIdentError, ">= 1", "substeps")
        check(self, JetIdentError, ">= 0", "noise_std_n", "delay_s", "throttle_step_pct")
        check(self, JetIdentError, "finite", "ambient_c", "ambient_drift_c", "reference_c")
        check(self, JetIdentError, "[low, high]", "ambient_c")
        check(self, JetIdentError, ">= 0", "seed", "train_seeds", "heldout_seeds")
        check(self, JetIdentError, "non-empty", "train_seeds")


@dataclass(frozen=True)
class ModelConfig:
    """The LSTM and the physical priors it is tried on (model.py); validation keeps one."""

    hidden: int = 32  # LSTM features
    priors: tuple[str, ...] = ("second_order", "first_order")
    max_delay_s: float = 0.12  # the longest dead time tried (0: none)

    def __post_init__(self) -> None:
        check(self, JetIdentError, ">= 1", "hidden")
        check(self, JetIdentError, ">= 0", "max_delay_s")
        check(self, JetIdentError, "non-empty", "priors")
        check(self, JetIdentError, "distinct", "priors")
        for prior in self.priors:
            if prior not in PRIORS:
                raise refusal(JetIdentError, "priors", f"a list of {', '.join(PRIORS)}", prior)


@dataclass(frozen=True)
class TrainConfig:
    """Truncated back-propagation through free-run windows: each window first runs `warmup`
    samples fed the measured thrust (to set the LSTM state), then `window` samples free-run on
    its own thrust; the loss is the mean squared free-run error (normalised)."""

    warmup: int = 50  # samples
    window: int = 300  # samples of free-run per window (gradient truncated at its start)
    batch: int = 32  # windows per step
    # then, from the best so far, windows this long (as many samples per step; 0: none)
    long_window: int = 1000
    learning_rate: float = 3e-3  # Adam, cosine-decayed to 5 % over max_steps
    max_steps: int = 3000
    clip_norm: float = 1.0  # gradient clipping (global norm)
    eval_every: int = 100  # steps between validation free-runs
    patience: int = 8  # validations without improvement before stopping early
    validation_fraction: float = 0.2  # this part of each log validates,
    validation_blocks: int = 4  # in blocks spread over it (the end of each of its quarters)
    max_minutes: float = 4.5  # stop training after this wall time
    seed: int = 0

    def __post_init__(self) -> None:
        check(self, JetIdentError, ">= 1", "warmup", "window", "batch", "max_steps")
        check(self, JetIdentError, ">= 1", "eval_every", "patience", "validation_blocks")
        check(self, JetIdentError, ">= 0", "long_window")
        check(self, JetIdentError, "> 0", "learning_rate", "clip_norm", "max_minutes")
        check(self, JetIdentError, "in (0, 1)", "validation_fraction")
        check(self, JetIdentError, ">= 0", "seed")


@dataclass(frozen=True)
class JetIdentConfig:
    bench: BenchConfig = BenchConfig()
    model: ModelConfig = ModelConfig()
    train: TrainConfig = TrainConfig()

    @classmethod
    def from_toml(cls, path: Path) -> JetIdentConfig:
        return cls.from_dict(read_toml(path, "config", JetIdentError), str(path))

    @classmethod
    def from_dict(cls, data: dict[str, Any], source: str = "<config>") -> JetIdentConfig:
        return load(cls, data, source, JetIdentError)

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)

    def to_toml(self) -> str:
        """The resolved config as TOML (what `from_toml` reads back)."""
        return to_toml(self.to_dict())
