"""motionkit: motion priors for a flying humanoid (iRonCub, or any jet-powered robot given by its
URDF and spec), from raw data to a trained policy.

Each stage is a subpackage with its front door in its docstring: motionkit.robot,
motionkit.mocap, motionkit.retarget, motionkit.trajopt, motionkit.jet_ident, motionkit.dataset,
motionkit.train, motionkit.viewer, motionkit.pipeline (imported on first use, e.g.
`motionkit.trajopt.TrajoptConfig` after `import motionkit`). Beside them: motionkit.cli (the
command line), and the plumbing every stage shares, by role: motionkit.core (errors, value
checks, TOML recipes, optional extras), motionkit.files (inputs, outputs, digests) and
motionkit.runtime (executors, workers, progress, interrupts).
"""

from __future__ import annotations

import importlib
from types import ModuleType

from motionkit.core.errors import MotionkitError
from motionkit.runtime.jaxcpu import avoid_lapack_deadlock

avoid_lapack_deadlock()

__version__ = "0.1.0"
STAGES = (
    "robot",
    "mocap",
    "retarget",
    "trajopt",
    "jet_ident",
    "dataset",
    "train",
    "viewer",
    "pipeline",
)
__all__ = ["STAGES", "MotionkitError", "__version__"]


def __getattr__(name: str) -> ModuleType:
    if name in STAGES:
        return importlib.import_module(f"motionkit.{name}")
    raise AttributeError(f"module 'motionkit' has no attribute {name!r}")
