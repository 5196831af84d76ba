"""A family of simulated engines for tests and the benchmark: the published P250, an engine
of the same structure with other coefficients and normalisation, and three of the spool
structure (spool.py), each on its own bench (noise, sensor low-pass, delay, ambient)."""

from __future__ import annotations

from dataclasses import replace

from motionkit.jet_ident.config import BenchConfig, P250Plant, SpoolPlant
from motionkit.jet_ident.p250 import P250_COEFFS, retimed

BASE = BenchConfig()
ENGINES: dict[str, BenchConfig] = {
    # the published P250 on the default bench
    "p250": BASE,
    # the same structure, a third slower, normalised to a larger engine (12-252 N); a slower,
    # later load cell on a colder bench
    "p250-slow": replace(
        BASE,
        p250=P250Plant(tuple(float(c) for c in retimed(P250_COEFFS, 0.75)), (125, 80, 50, 33)),
        sensor_cutoff_hz=3.0,
        delay_s=0.05,
        ambient_c=(0.0, 10.0),
    ),
    # a P250-sized first-order spool engine (11-230 N)
    "spool": replace(BASE, plant="spool", spool=SpoolPlant(accel_limit=(0.5, 0.6))),
    # a larger, slower engine with a fuel lag (second order, 19-300 N), noisier
    "spool-lag": replace(
        BASE,
        plant="spool",
        spool=SpoolPlant(300.0, 0.3, 2.3, 0.4, (0.4, 0.5), 0.15),
        noise_std_n=2.0,
        sensor_cutoff_hz=4.0,
        delay_s=0.04,
    ),
    # a small, quick engine (6-160 N) on a hot bench that warms by 3 degC
    "spool-small": replace(
        BASE,
        plant="spool",
        spool=SpoolPlant(160.0, 0.3, 2.7, 0.18, (0.9, 1.2), 0.05),
        noise_std_n=1.0,
        sensor_cutoff_hz=8.0,
        delay_s=0.02,
        ambient_c=(25.0, 35.0),
        ambient_drift_c=3.0,
    ),
}
