"""MuJoCo MJX, imported quietly: without NVIDIA's warp (every CPU machine, where MJX runs on
JAX) the import prints "Failed to import warp" and "Failed to import mujoco_warp", which say
nothing about motionkit's runs. Import `mjx` from here."""

import contextlib
import io

with contextlib.redirect_stdout(io.StringIO()):
    from mujoco import mjx

__all__ = ["mjx"]
