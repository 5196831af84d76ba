"""The motionkit error family: one clear line naming the file, the field and what was expected."""


class MotionkitError(Exception):
    """Base of every error motionkit raises on bad input."""


class RobotModelError(MotionkitError):
    """A robot description (URDF or spec TOML) lacks something motionkit needs or is invalid."""


class MissingExtraError(MotionkitError):
    """An optional dependency group is not installed."""

    def __init__(self, extra: str, module: str) -> None:
        super().__init__(
            f"this command needs the '{extra}' extra ({module} is not installed): "
            f"pip install 'motionkit[{extra}]'"
        )


def require(module: str, extra: str):
    """Import an optional module, or raise MissingExtraError naming the extra to install."""
    import importlib

    try:
        return importlib.import_module(module)
    except ImportError as exc:
        raise MissingExtraError(extra, module) from exc
