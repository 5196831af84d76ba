"""JAX on a CPU: one XLA worker thread where batched LAPACK calls deadlock.

jaxlib 0.10.0 to 0.11.x splits a batched LAPACK kernel (Cholesky, triangular solve) into chunks
on the CPU client's worker threads and blocks its own thread until they finish; when every worker
blocks at once, nothing is left to run the chunks. MJX's step holds several such calls side by
side, so on a 2-core machine a batch of 256 or more environments hangs after compiling. With one
worker (`PJRT_NPROC=1`) each kernel runs its batch inline; on 2 cores it costs little (about the
steps/s of jaxlib 0.9.2). The variable is read when JAX creates its CPU client (the first
computation, not the import), so `avoid_lapack_deadlock` runs when motionkit is imported. GPU
installs and a `PJRT_NPROC` of the user's own are left alone."""

from __future__ import annotations

import os
from importlib.metadata import PackageNotFoundError, entry_points, version

AFFECTED = ((0, 10), (0, 11))  # jaxlib minor releases that split batched LAPACK calls


def _jaxlib() -> tuple[int, int] | None:
    try:
        major, minor = version("jaxlib").split(".")[:2]
        return int(major), int(minor)
    except (PackageNotFoundError, ValueError):
        return None


def _gpu_plugin() -> bool:
    platforms = os.environ.get("JAX_PLATFORMS", "").strip().lower()
    if platforms:
        return platforms != "cpu"
    plugins = entry_points(group="jax_plugins")
    return any(p.name.startswith(("xla_cuda", "xla_rocm")) for p in plugins)


def avoid_lapack_deadlock() -> None:
    """One XLA CPU worker where the jaxlib in use deadlocks (see the module doc)."""
    if "PJRT_NPROC" in os.environ or _jaxlib() not in AFFECTED or _gpu_plugin():
        return
    os.environ["PJRT_NPROC"] = "1"
