"""The motionkit error family: one clear line naming the file, the field and what was expected."""


class MotionkitError(Exception):
    """Base of every error motionkit raises on bad input."""


class RobotModelError(MotionkitError):
    """A robot description (URDF or spec TOML) lacks something motionkit needs or is invalid."""


class DatasetError(MotionkitError):
    """A motion clip or dataset is malformed, corrupt, or does not match its robot."""


class MocapError(MotionkitError):
    """A mocap file (BVH, ASF/AMC) or landmark mapping is malformed or cannot be interpreted."""


class RetargetError(MotionkitError):
    """A retargeting input or config is invalid, or the motion cannot be retargeted."""


class TrajoptError(MotionkitError):
    """A trajectory-optimisation request is invalid, or its problem is infeasible."""


class JetIdentError(MotionkitError):
    """A jet bench log, thrust model file or identification config is malformed."""


class TrainError(MotionkitError):
    """A training config, prior dataset, checkpoint or run folder is invalid or missing."""


class ViewerError(MotionkitError):
    """A clip, folder or run given to the viewer is missing, corrupt or not for this robot."""


class PipelineError(MotionkitError):
    """A pipeline config is invalid, or one of its stages failed."""
