"""The retargeting config: one frozen dataclass, defaults here, filled from TOML recipes."""

from __future__ import annotations

from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

from motionkit.errors import RetargetError
from motionkit.tomlfile import build_dataclass, read_toml


@dataclass(frozen=True)
class Weights:
    """PlaCo soft-task weights (dimensionless; the relative size is what matters)."""

    foot_position: float = 1000.0
    foot_orientation: float = 100.0
    pelvis_position: float = 10.0
    pelvis_orientation: float = 5.0
    torso_orientation: float = 2.0
    knee: float = 1.0
    elbow: float = 0.5
    posture: float = 1e-3


@dataclass(frozen=True)
class RobotPoints:
    """Robot points matched to the human's: where the axes of these joints meet ('{s}' = l/r),
    and the frame whose orientation follows the human chest."""

    hip: tuple[str, ...] = ("{s}_hip_pitch", "{s}_hip_roll", "{s}_hip_yaw")
    knee: tuple[str, ...] = ("{s}_knee",)
    ankle: tuple[str, ...] = ("{s}_ankle_pitch", "{s}_ankle_roll")
    shoulder: tuple[str, ...] = ("{s}_shoulder_pitch", "{s}_shoulder_roll", "{s}_shoulder_yaw")
    elbow: tuple[str, ...] = ("{s}_elbow",)
    sides: tuple[str, str] = ("l", "r")  # the prefixes of the left and right joints
    torso_frame: str = "chest"


@dataclass(frozen=True)
class RetargetConfig:
    kind: str = "walk"  # dataset label of the output
    # Landmarks are low-passed (zero-phase Butterworth, 2nd order) at this cut-off [Hz]; 0: off.
    # 6 Hz is the usual choice for gait mocap; it removes marker jitter that the IK would chase.
    smoothing_hz: float = 6.0
    # Human foot contact: foot height above the ground [m] and horizontal speed [m/s] below
    # these (human scale); runs and gaps shorter than min_run [s] are removed.
    contact_height: float = 0.06
    contact_speed: float = 0.35
    min_run: float = 0.05
    # After a contact ends, the locked foot target blends back to the human's over this time [s].
    release_time: float = 0.2
    # The human upper arms are turned outward by this angle [rad]: iRonCub's arm jets would
    # otherwise hit its chest jets when the arms hang down.
    arm_abduction: float = 0.35
    # Self-collision avoidance (PlaCo, hard constraint) between the capsules of limbs, feet and
    # jets (motionkit/retarget/bodies.py) that do not share a joint: kept this far apart [m].
    self_collisions: bool = True
    collision_margin: float = 0.005
    iterations: int = 2  # PlaCo solves per frame (warm-started from the previous frame)
    settle_iterations: int = 100  # solves on the first frame
    velocity_limits: bool = True
    weights: Weights = Weights()
    points: RobotPoints = RobotPoints()
    # Clips: files, folders or CMU clip ids (a recipe's list; the CLI's inputs are added).
    clips: tuple[str, ...] = field(default_factory=tuple)

    def __post_init__(self) -> None:
        from motionkit.dataset.trajectory import KINDS

        if self.kind not in KINDS:
            raise RetargetError(f"kind '{self.kind}' is not one of {', '.join(KINDS)}")

    @classmethod
    def from_toml(cls, path: Path) -> RetargetConfig:
        return cls.from_dict(read_toml(path, "config", RetargetError), str(path))

    @classmethod
    def from_dict(cls, data: dict[str, Any], source: str = "<config>") -> RetargetConfig:
        nested = {"weights": Weights, "points": RobotPoints}
        values: dict[str, Any] = {}
        for key, value in data.items():
            if key in nested:
                values[key] = _build(nested[key], value, f"{source}: [{key}]")
            else:
                values[key] = value
        return _build(cls, values, source)

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)


def _build(cls: type, values: dict[str, Any], where: str) -> Any:
    return build_dataclass(cls, values, where, RetargetError)
