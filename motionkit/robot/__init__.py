"""The robot model every stage shares: iRonCub built from icub-models, or a user URDF + spec."""

from motionkit.robot.model import JointLimits, Robot, cache_dir, ironcub, load_robot
from motionkit.robot.spec import THRUST_AXIS, FootSpec, JetSpec, RobotSpec

__all__ = [
    "THRUST_AXIS",
    "FootSpec",
    "JetSpec",
    "JointLimits",
    "Robot",
    "RobotSpec",
    "cache_dir",
    "ironcub",
    "load_robot",
]
