"""What a training process sets up first: the [train] extra, checked, and XLA's compile cache."""

from __future__ import annotations

import os

from motionkit.errors import TrainError
from motionkit.extras import require


def require_train_extra(what: str = "train") -> None:
    """TrainError naming `what` and the [train] extra when JAX, flax, optax or MuJoCo is
    missing."""
    require("train", what, TrainError, ("jax", "flax", "optax", "mujoco"))
    from motionkit.train.env.mjx import mjx  # noqa: F401  (quietly: no warp notice)


def enable_compile_cache() -> None:
    """Keep XLA's compiled programs in the user cache's jax/ (or at JAX_COMPILATION_CACHE_DIR,
    JAX's own variable, where it is set: a cache that machines or jobs share): a resumed run
    or the next setting of an ablation skips most of the minutes MJX takes to compile."""
    import jax

    from motionkit.robot import cache_dir

    folder = os.environ.get("JAX_COMPILATION_CACHE_DIR") or str(cache_dir() / "jax")
    jax.config.update("jax_compilation_cache_dir", folder)
    jax.config.update("jax_persistent_cache_min_compile_time_secs", 2.0)
