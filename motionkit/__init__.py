"""motionkit: motion priors for a flying humanoid (iRonCub), from raw data to a trained policy."""

from motionkit.errors import MotionkitError

__version__ = "0.1.0"
__all__ = ["MotionkitError", "__version__"]
