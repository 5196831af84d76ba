"""A synthetic JetCat P250 test bench: realistic identification logs from an engine model.

No P250 bench log is public, so logs are made from an engine model, by default the published
second-order P250 model (p250.py; `plant = "p250"` with any coefficients and normalisation,
`plant = "rate_form"`, the structure published for the P100/P220, or `plant = "spool"`, the
shaft-speed model of spool.py), with the imperfections of a real bench,
in this order (all in BenchConfig, all seeded):

1. Identification profile: after 5 s at idle, a random sequence of steps (held 2-8 s), ramps
   (2-20 s, then held 1-4 s) and exponential chirps (0.01 Hz up to 0.2-0.6 Hz, amplitude 5-20 %,
   20-60 s) around 10/30/50/70/90 % (+-5 %), ending with 8 s at idle. The logged throttle is
   this command (0.01 % resolution).
2. The engine sees the command `delay_s` later (whole samples), quantised to
   `throttle_step_pct` (the ECU's resolution).
3. The engine: its model, `substeps` RK4 steps per sample, starting at equilibrium.
4. Ambient temperature: thrust scales with air density, gain = (273.15 + reference_c) /
   (273.15 + ambient); the ambient is drawn uniformly in `ambient_c` per log and rises by
   `ambient_drift_c` over the log as the bench warms.
5. The load cell: a first-order low-pass at `sensor_cutoff_hz` (on the fine time grid), then
   white Gaussian noise of `noise_std_n`, logged at `rate_hz`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.signal import lfilter

from motionkit.jet_ident import spool
from motionkit.jet_ident.benchlog import BenchLog
from motionkit.jet_ident.config import BenchConfig
from motionkit.jet_ident.integrate import integrate, simulate
from motionkit.jet_ident.p250 import steady_thrust

LEVELS = (10.0, 30.0, 50.0, 70.0, 90.0)  # % throttle the profile moves around
SOURCES = {
    "p250": "published second-order model",
    "rate_form": "second-order model of the P100/P220 structure",
    "spool": "spool model",
}


@dataclass(frozen=True)
class SyntheticRun:
    log: BenchLog  # what the bench records
    clean: np.ndarray  # the load cell's signal before noise [N] (for the noise floor)
    engine_thrust: np.ndarray  # the engine's thrust at the log's samples [N]
    ambient_c: float  # ambient temperature at the start [degC]


def identification_profile(
    duration_s: float, rate_hz: float, rng: np.random.Generator
) -> np.ndarray:
    """Throttle [%] at `rate_hz` for `duration_s` (see the module doc, item 1).

    Args:
        duration_s: the profile's length [s].
        rate_hz: its sample rate [Hz].
        rng: the random generator that draws its segments.

    Returns:
        The throttle command [%], shape (round(duration_s * rate_hz),), 0 to 100 at 0.01 %
        resolution, from 5 s at idle to 8 s at idle.
    """
    n = round(duration_s * rate_hz)
    parts = [np.zeros(round(5 * rate_hz))]
    current = 0.0
    while sum(len(p) for p in parts) < n:
        kind = rng.choice(3, p=[0.4, 0.3, 0.3])
        target = float(np.clip(rng.choice(LEVELS) + rng.uniform(-5, 5), 0, 100))
        if kind == 0:  # step and hold
            segment = np.full(round(rng.uniform(2, 8) * rate_hz), target)
        elif kind == 1:  # ramp, then hold
            ramp = np.linspace(current, target, round(rng.uniform(2, 20) * rate_hz))
            segment = np.concatenate([ramp, np.full(round(rng.uniform(1, 4) * rate_hz), target)])
        else:  # exponential chirp around the current level
            seconds = rng.uniform(20, 60)
            f0, f1 = 0.01, rng.uniform(0.2, 0.6)
            t = np.arange(round(seconds * rate_hz)) / rate_hz
            rate = np.log(f1 / f0) / seconds
            phase = 2 * np.pi * f0 * np.expm1(rate * t) / rate
            centre = float(np.clip(current, 10, 90))
            amplitude = rng.uniform(5, 20)
            segment = np.clip(centre + amplitude * np.sin(phase), 0, 100)
        parts.append(segment)
        current = float(segment[-1])
    end = round(8 * rate_hz)
    profile = np.concatenate(parts)[: max(n - end, 0)]
    down = np.linspace(current, 0.0, round(rate_hz))
    profile = np.concatenate([profile, down, np.zeros(end)])[:n]
    return np.round(profile, 2)


def engine_thrust(config: BenchConfig, throttle: np.ndarray, h: float) -> np.ndarray:
    """The engine's thrust [N] at the start of each step of `h` under `throttle` (one value per
    step), one RK4 step each, from rest at the first throttle."""
    if config.plant == "spool":
        plant = config.spool
        start = spool.rest(plant, float(throttle[0]))
        states = integrate(spool.derivative, plant, None, throttle, h, start, 1)
        speed = np.concatenate([[start[0]], states[:-1, 0]])
        return spool.thrust(plant, speed)
    coeffs, scales = config.second_order()
    start = float(steady_thrust(coeffs, throttle[0], scales))
    states = simulate(coeffs, throttle, h, start, 0.0, substeps=1, scales=scales)
    return np.concatenate([[start], states[:-1, 0]])


def synthetic_run(
    config: BenchConfig,
    seed: int,
    throttle: np.ndarray | None = None,
    ambient_c: float | None = None,
) -> SyntheticRun:
    """One synthetic bench log of the config's engine, with the bench's imperfections.

    The engine runs on `throttle` (by default the seeded identification profile), starting at
    `ambient_c` (by default drawn in the config's range); see the module doc for the steps.

    Args:
        config: the bench: engine model, profile length, rate, delay, ECU resolution,
            ambient, load cell and noise.
        seed: the seed of the profile, the ambient draw and the noise; it names the log
            ("p250_seed{seed}").
        throttle: the logged throttle command [%], shape (samples,), at the config's rate
            (None: `identification_profile` of the config's duration).
        ambient_c: the ambient temperature at the start [degC] (None: drawn).

    Returns:
        The SyntheticRun: the log (time [s], throttle [%], measured thrust [N] to 1 mN, the
        bench's figures as metadata), the load cell's signal before noise [N], the engine's
        thrust at the samples [N] and the starting ambient [degC].
    """
    rng = np.random.default_rng(seed)
    dt = 1.0 / config.rate_hz
    if throttle is None:
        throttle = identification_profile(config.duration_s, config.rate_hz, rng)
    n = len(throttle)
    delay = round(config.delay_s / dt)
    engine_u = np.concatenate([np.full(delay, throttle[0]), throttle[: n - delay]])
    if config.throttle_step_pct > 0:
        engine_u = np.round(engine_u / config.throttle_step_pct) * config.throttle_step_pct

    h = dt / config.substeps
    thrust = engine_thrust(config, np.repeat(engine_u, config.substeps), h)

    ambient0 = rng.uniform(*config.ambient_c)  # drawn either way: the noise stays the same
    ambient0 = ambient0 if ambient_c is None else ambient_c
    ambient = ambient0 + config.ambient_drift_c * np.arange(n * config.substeps) / (
        n * config.substeps
    )
    gain = (273.15 + config.reference_c) / (273.15 + ambient)
    force = gain * thrust
    a = np.exp(-2 * np.pi * config.sensor_cutoff_hz * h)
    sensor, _ = lfilter([1 - a], [1, -a], force, zi=[a * force[0]])
    clean = sensor[:: config.substeps]
    measured = clean + config.noise_std_n * rng.standard_normal(n)

    metadata = {
        "source": f"motionkit synthetic P250 bench ({SOURCES[config.plant]})",
        "seed": str(seed),
        "ambient_c": f"{ambient0:.2f}",
        "noise_std_n": f"{config.noise_std_n:g}",
        "sensor_cutoff_hz": f"{config.sensor_cutoff_hz:g}",
        "delay_s": f"{delay * dt:g}",
        "throttle_step_pct": f"{config.throttle_step_pct:g}",
    }
    log = BenchLog(np.arange(n) * dt, throttle, np.round(measured, 3), f"p250_seed{seed}", metadata)
    return SyntheticRun(log, clean, gain[:: config.substeps] * thrust[:: config.substeps], ambient0)
