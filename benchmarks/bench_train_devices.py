"""Training throughput (env-steps/s, rollout and PPO update together) of the two MJX backends
side by side (impl "jax" and "warp") and on 1 against 2 devices of this host, for a list of
environment counts, all in one run.

    python benchmarks/bench_train_devices.py                         # GPU: 4096 and 8192 envs
    python benchmarks/bench_train_devices.py --envs 16 32 --host-devices 2   # CPU, 2 host devices

A setting this machine cannot run (warp without an NVIDIA GPU or warp-lang, more devices than
it has) is printed as skipped, with the reason. `--host-devices N` makes N CPU host devices
(XLA_FLAGS, set before JAX starts): they share the same cores, so on a CPU the comparison
shows the cost of the split, not a speed-up.
"""

from __future__ import annotations

import argparse
import os
from dataclasses import replace
from pathlib import Path


def parse() -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--envs", type=int, nargs="+", help="env counts (gpu 4096 8192, cpu 32 64)")
    parser.add_argument("--impls", nargs="+", default=["jax", "warp"], choices=("jax", "warp"))
    parser.add_argument("--devices", type=int, nargs="+", default=[1, 2], help="device counts")
    parser.add_argument("--iterations", type=int, default=3, help="timed iterations")
    parser.add_argument("--config", type=Path, help="recipe (default train/paper_gpu.toml)")
    parser.add_argument("--host-devices", type=int, help="CPU host devices to force (XLA_FLAGS)")
    return parser.parse_args()


def skipped(impl: str, devices: int, envs: int) -> str | None:
    """Why this machine cannot run the setting (None: it can)."""
    import jax

    from motionkit.train.env.mjx import warp_missing

    if impl == "warp" and warp_missing():
        return f"warp needs {warp_missing()}"
    if devices > jax.local_device_count():
        return f"{jax.local_device_count()} local device(s)"
    if envs % devices:
        return f"{envs} envs do not split over {devices} devices"
    return None


def main() -> None:
    args = parse()
    if args.host_devices:  # read when JAX starts: before the first import of jax
        flag = f"--xla_force_host_platform_device_count={args.host_devices}"
        os.environ["XLA_FLAGS"] = f"{os.environ.get('XLA_FLAGS', '')} {flag}".strip()
    import jax
    from bench_train import RECIPE, sized, training_rate

    from motionkit.train.config import TrainConfig

    gpu = jax.default_backend() == "gpu"
    counts = args.envs or ([4096, 8192] if gpu else [32, 64])
    recipe = args.config or RECIPE
    base = TrainConfig.from_toml(recipe)
    device = jax.devices()[0]
    print(
        f"{recipe.name}; jax {jax.__version__} on {jax.local_device_count()} x "
        f"{device.device_kind}; {args.iterations} timed iterations after the first"
    )
    for envs in counts:
        rates: dict[tuple[str, int], float] = {}
        for impl in args.impls:
            for devices in args.devices:
                label = f"  {envs:>6} envs, impl {impl:<4}, {devices} device(s):"
                reason = skipped(impl, devices, envs)
                if reason:
                    print(f"{label} skipped ({reason})", flush=True)
                    continue
                config = sized(base, envs)
                config = replace(
                    config,
                    env=replace(config.env, impl=impl),
                    run=replace(config.run, devices=devices),
                )
                whole, rollout, compile_s = training_rate(config, args.iterations)
                rates[impl, devices] = whole
                print(
                    f"{label} training {whole:>10,.0f} env-steps/s, rollout alone "
                    f"{rollout:>10,.0f} (first iteration incl. compile {compile_s:.0f} s)",
                    flush=True,
                )
        _ratios(envs, rates)


def _ratios(envs: int, rates: dict[tuple[str, int], float]) -> None:
    """The speed-ups of warp over jax and of 2 devices over 1 where both were measured."""
    for devices in sorted({d for _, d in rates}):
        if ("jax", devices) in rates and ("warp", devices) in rates:
            ratio = rates["warp", devices] / rates["jax", devices]
            print(f"  {envs} envs, {devices} device(s): warp / jax x{ratio:.2f}")
    for impl in sorted({i for i, _ in rates}):
        if (impl, 1) in rates and (impl, 2) in rates:
            print(
                f"  {envs} envs, impl {impl}: 2 / 1 devices x{rates[impl, 2] / rates[impl, 1]:.2f}"
            )


if __name__ == "__main__":
    main()
