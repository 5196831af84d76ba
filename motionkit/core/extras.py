"""The optional extras of the distribution, and the one check that a command's extra is there."""

from __future__ import annotations

import contextlib
import importlib
import io

from motionkit.core.errors import MotionkitError

# extra -> the modules it installs that motionkit imports
EXTRAS: dict[str, tuple[str, ...]] = {
    "ik": ("pinocchio", "placo"),
    "trajopt": ("casadi", "adam.casadi"),
    "train": ("jax", "flax", "optax", "mujoco", "mujoco.mjx"),
    "viewer": ("viser", "trimesh"),
    "cluster": ("ray",),
}


def require(
    extra: str, what: str, error: type[MotionkitError], modules: tuple[str, ...] = ()
) -> None:
    """Import the extra's modules (or just `modules` of it) quietly (MJX prints a line for each
    optional backend it lacks); `error` naming `what`, the module missing and the extra to
    install when one cannot be imported."""
    for module in modules or EXTRAS[extra]:
        try:
            with contextlib.redirect_stdout(io.StringIO()):
                importlib.import_module(module)
        except ImportError as exc:
            missing = exc.name or module
            raise error(
                f"{what} needs the [{extra}] extra ({missing} is missing): "
                f"pip install 'motionkit[{extra}]'"
            ) from exc
