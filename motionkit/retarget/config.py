"""The retargeting config: one frozen dataclass, defaults here, filled from TOML recipes."""

from __future__ import annotations

from dataclasses import asdict, dataclass, field, fields
from pathlib import Path
from typing import Any

from motionkit.core.checks import check
from motionkit.core.errors import RetargetError
from motionkit.core.tomlfile import load, read_toml


@dataclass(frozen=True)
class Weights:
    """PlaCo soft-task weights (dimensionless; the relative size is what matters)."""

    foot_position: float = 1000.0
    foot_orientation: float = 100.0
    # a sole in contact, when contacts are soft (hard_contacts false), and one just released
    # (blended out over the release time): above the swinging one's
    contact_foot_position: float = 100000.0
    contact_foot_orientation: float = 10000.0
    pelvis_position: float = 10.0
    pelvis_orientation: float = 5.0
    torso_orientation: float = 2.0
    knee: float = 1.0
    elbow: float = 0.5
    posture: float = 1e-3

    def __post_init__(self) -> None:
        check(self, RetargetError, ">= 0", *(item.name for item in fields(self)))


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

    def __post_init__(self) -> None:
        check(self, RetargetError, "non-empty", "hip", "knee", "ankle", "shoulder", "elbow")


@dataclass(frozen=True)
class Balance:
    """The dynamic filter (motionkit/retarget/balance.py): the base moves horizontally so that
    the centre of pressure the motion needs stays inside the support."""

    passes: int = 2  # filter passes (each re-solves the IK); 0: off
    # m: the CoP is aimed this far inside the support polygon's edges (one larger than the
    # polygon's inradius aims at its centre: a sole is about 3 cm from centre to side edge)
    margin: float = 0.04
    # A frame's CoP error counts up to this size [m]: a larger one (an impact, a hop's
    # landing) is beyond what a smooth shift of the CoM can undo.
    error_cap: float = 0.1
    max_shift: float = 0.1  # m: the base moves at most this far from the retargeted one
    stay: float = 1e-2  # weight of the shift's size against the CoP error (m^2 per m^2)
    smooth: float = 1e-2  # weight of the shift's own cart-table CoP swing (its acceleration)

    def __post_init__(self) -> None:
        check(self, RetargetError, ">= 0", "passes", "margin", "stay", "smooth")
        check(self, RetargetError, "> 0", "error_cap", "max_shift")


@dataclass(frozen=True)
class CleanWalk:
    """The quality gate: the figures of a clean retargeted walk. A clip beyond any of them is a
    failed clip (not written to the output folder, unless kept in another)."""

    foot_slide_p95_m_s: float = 0.003  # m/s: a planted foot (hard contacts) does not slide
    penetration_max_m: float = 0.001
    joint_position_violations: int = 0
    joint_velocity_violations: int = 0
    feet_error_mean_m: float = 0.03

    def __post_init__(self) -> None:
        check(self, RetargetError, ">= 0", *(item.name for item in fields(self)))


@dataclass(frozen=True)
class RetargetConfig:
    kind: str = "walk"  # dataset label of the output
    # Landmarks are low-passed (zero-phase Butterworth, 2nd order) at this cut-off [Hz]; 0: off.
    # 6 Hz is the usual choice for gait mocap; it removes marker jitter that the IK would chase.
    smoothing_hz: float = 6.0
    # Human foot contact (human scale): the foot lands when its lower end (ankle or toe) is
    # within contact_height [m] of where it stands and the slower of the two moves slower than
    # contact_speed [m/s] (vertical motion included); it lifts off when either passes
    # contact_hysteresis (>= 1) times its threshold. Runs and gaps shorter than min_run [s] are
    # removed.
    contact_height: float = 0.03
    contact_speed: float = 0.35
    contact_hysteresis: float = 1.2
    min_run: float = 0.05
    # Where a foot stands: per landmark, its lowest within ground_window [s] either side of a
    # frame, but at most ground_range [m] above that landmark's lowest on either foot (human
    # scale).
    ground_window: float = 1.0
    ground_range: float = 0.08
    # Over this time [s] before a contact the foot target closes in on where it will be locked
    # (a foot that lands moving stops above its place), and after one it blends back to the
    # human's.
    release_time: float = 0.2
    # A swinging sole's lowest corner stays this high [m] above the ground (blended in over the
    # release time): the human's toe-off skims the floor, which a robot's flat sole would drag.
    swing_clearance: float = 0.015
    # The human upper arms are turned outward by this angle [rad]: iRonCub's arm jets would
    # otherwise hit its chest jets when the arms hang down.
    arm_abduction: float = 0.35
    # Self-collision avoidance (PlaCo, hard constraint) between the capsules of limbs, feet and
    # jets (motionkit/retarget/bodies.py) that do not share a joint: kept this far apart [m].
    self_collisions: bool = True
    collision_margin: float = 0.005
    # The robot performs the clip this many times slower than the human did (targets are made
    # in the human's time, then stretched): a slower walk asks less of ankles and knees.
    slowdown: float = 1.0
    # Each frame is solved to convergence, warm-started from the previous one: PlaCo solves
    # until the largest component of a step (rad, or m for the base) is below `tolerance`, at
    # most `iterations` of them (`settle_iterations` on the first frame, from the standing
    # posture). A frame stopped short of its solution would carry its error into the next ones,
    # and another CPU's rounding would then give another motion.
    tolerance: float = 1e-9
    iterations: int = 100
    settle_iterations: int = 100
    # Joint velocity limits hold from frame to frame: each joint moves at most its limit times
    # the frame time away from where the previous frame left it.
    velocity_limits: bool = True
    # A foot in contact is held by a hard constraint where the robot's sole was when the
    # contact began (x, y, yaw; flat on the ground) for the whole contact: it cannot slide;
    # false: a heavily weighted soft task (`weights.contact_foot_*`) instead.
    hard_contacts: bool = True
    weights: Weights = Weights()
    points: RobotPoints = RobotPoints()
    balance: Balance = Balance()
    quality: CleanWalk = CleanWalk()  # [quality]: looser for a robot or take that needs it
    # Clips: files, folders or CMU clip ids (a recipe's list; the CLI's inputs are added).
    clips: tuple[str, ...] = field(default_factory=tuple)
    # The part of a clip that is retargeted, by clip name (file stem): [start, end] in seconds of
    # the mocap, for takes that hold more than the motion wanted (a kick after a walk).
    trim: dict[str, tuple[float, float]] = field(default_factory=dict)

    def __post_init__(self) -> None:
        from motionkit.dataset.trajectory import KINDS

        check(self, RetargetError, KINDS, "kind")
        positive = ("contact_height", "contact_speed", "ground_window", "release_time", "slowdown")
        check(self, RetargetError, "> 0", *positive)
        check(self, RetargetError, ">= 0", "smoothing_hz", "min_run", "ground_range")  # 0: off
        check(self, RetargetError, ">= 0", "collision_margin", "swing_clearance")
        check(self, RetargetError, ">= 1", "contact_hysteresis", "iterations", "settle_iterations")
        check(self, RetargetError, "> 0", "tolerance")
        check(self, RetargetError, "finite", "arm_abduction")
        for name, (start, end) in self.trim.items():
            if not 0.0 <= start < end < float("inf"):
                raise RetargetError(
                    f"trim '{name}': [{start}, {end}] is not a time range (0 <= start < end)"
                )

    @classmethod
    def from_toml(cls, path: Path) -> RetargetConfig:
        return cls.from_dict(read_toml(path, "config", RetargetError), str(path))

    @classmethod
    def from_dict(cls, data: dict[str, Any], source: str = "<config>") -> RetargetConfig:
        return load(cls, data, source, RetargetError)

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)
