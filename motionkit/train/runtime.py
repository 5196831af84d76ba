"""What a training process sets up first: the [train] extra, checked, and XLA's compile cache."""

from __future__ import annotations

import os

from motionkit.core.errors import TrainError
from motionkit.core.extras import require


def require_train_extra(what: str = "train") -> None:
    """Check up front that the [train] extra imports.

    JAX, flax, optax and MuJoCo are imported (quietly), and MJX with them.

    Args:
        what: what needs the extra, as the error names it.

    Returns:
        None, once every module imported.

    Raises:
        TrainError: naming `what`, the missing module and the [train] extra to install.
    """
    require("train", what, TrainError, ("jax", "flax", "optax", "mujoco"))
    from motionkit.train.env.mjx import mjx  # noqa: F401  (quietly: no warp notice)


def enable_compile_cache() -> None:
    """Keep XLA's compiled programs in a persistent cache.

    The cache is the user cache's jax/ (or JAX_COMPILATION_CACHE_DIR, JAX's own variable,
    where it is set: a cache that machines or jobs share); programs that took 2 s or more to
    compile are kept. A resumed run or the next setting of an ablation then skips most of the
    minutes MJX takes to compile. Needs JAX (the [train] extra).

    Returns:
        None; JAX's config is set for the rest of the process.
    """
    import jax

    from motionkit.robot import cache_dir

    folder = os.environ.get("JAX_COMPILATION_CACHE_DIR") or str(cache_dir() / "jax")
    jax.config.update("jax_compilation_cache_dir", folder)
    jax.config.update("jax_persistent_cache_min_compile_time_secs", 2.0)
