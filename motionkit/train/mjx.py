"""MuJoCo MJX, imported quietly: without NVIDIA's warp (every CPU machine, where MJX runs on
JAX) the import prints "Failed to import warp" and "Failed to import mujoco_warp", which say
nothing about motionkit's runs. Import `mjx` from here.

`warp_missing()` says what the MuJoCo Warp backend (`impl = "warp"`) lacks on this machine:
the warp-lang package (`motionkit[warp]`) and an NVIDIA GPU that JAX sees (CUDA plugin)."""

import contextlib
import importlib.util
import io

import jax

with contextlib.redirect_stdout(io.StringIO()):
    from mujoco import mjx
    from mujoco.mjx import warp as mjx_warp

__all__ = ["mjx", "warp_missing"]


def _cuda_devices() -> list[jax.Device]:
    try:
        return jax.devices("cuda")
    except RuntimeError:  # no CUDA backend in this JAX
        return []


def warp_missing() -> str | None:
    """What the warp backend lacks here, in words (None: nothing)."""
    missing = []
    if importlib.util.find_spec("warp") is None or not mjx_warp.WARP_INSTALLED:
        missing.append("NVIDIA's warp-lang package (pip install 'motionkit[warp]')")
    if not _cuda_devices():
        platforms = sorted({d.platform for d in jax.devices()})
        missing.append(f"an NVIDIA GPU with JAX's CUDA plugin (JAX sees {', '.join(platforms)})")
    return " and ".join(missing) or None
