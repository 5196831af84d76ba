"""MuJoCo MJX, imported quietly: without NVIDIA's warp (every CPU machine, where MJX runs on
JAX) the import prints "Failed to import warp" and "Failed to import mujoco_warp", which say
nothing about motionkit's runs. Import `mjx` from here.

`warp_missing()` says what the MuJoCo Warp backend (`impl = "warp"`) lacks on this machine:
the warp-lang package (`motionkit[warp]`) and an NVIDIA GPU that JAX sees (CUDA plugin)."""

import contextlib
import importlib.util
import io

import jax
import mujoco

from motionkit.core.errors import TrainError

with contextlib.redirect_stdout(io.StringIO()):
    from mujoco import mjx
    from mujoco.mjx import warp as mjx_warp

__all__ = ["mjx", "put_on_backend", "warp_missing"]


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


def put_on_backend(
    model: mujoco.MjModel, data: mujoco.MjData, impl: str, worlds: int
) -> tuple[mjx.Model, mjx.Data]:
    """The MJX model and data on backend `impl` ("jax" or "warp"). MuJoCo Warp allocates its
    contacts for all the worlds stepped together (`worlds`, the environments on one device) and
    its constraints per world: as many as MJX-JAX has (every candidate contact)."""
    if impl == "jax":
        return mjx.put_model(model, impl="jax"), mjx.put_data(model, data, impl="jax")
    missing = warp_missing()
    if missing:
        raise TrainError(f"[env] impl = 'warp' needs {missing}")
    sizes = mjx.put_data(model, data, impl="jax")._impl  # MJX-JAX's static contact arrays
    warp_data = mjx.put_data(
        model,
        data,
        impl="warp",
        naconmax=max(1, sizes.ncon) * worlds,
        njmax=max(1, sizes.efc_J.shape[0]),
    )
    return mjx.put_model(model, impl="warp"), warp_data
