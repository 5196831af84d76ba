"""The robot spec: what a robot must declare for motionkit (a TOML file beside its URDF).

Joint order, feet and sole corners, jets and their thrust limits, the arm end effectors, the
facing direction of the base, limit defaults and simulation settings. The built-in iRonCub spec
is `ironcub.toml` in this folder; a user robot passes its own with `--spec`.
"""

from __future__ import annotations

import fnmatch
import math
import re
import tomllib
from dataclasses import dataclass
from importlib import resources
from pathlib import Path
from typing import Any

from motionkit.core.checks import check, refusal
from motionkit.core.errors import RobotModelError
from motionkit.core.tomlfile import load, read_toml

# Thrust acts along this axis of every jet frame (the frame origin is at the nozzle).
THRUST_AXIS = (0.0, 0.0, -1.0)
# The name becomes file and folder names (exports, the robot cache): a plain one only.
PLAIN_NAME = re.compile(r"[A-Za-z0-9_-][A-Za-z0-9_.-]{0,63}")
PLAIN_NAME_RULE = "1-64 letters, digits, '_', '-' or '.' (not first)"


@dataclass(frozen=True)
class FootSpec:
    side: str
    sole: str
    corners: tuple[str, ...]

    def __post_init__(self) -> None:
        check(self, RobotModelError, "non-empty", "corners")


@dataclass(frozen=True)
class JetSpec:
    name: str
    frame: str
    t_max: float  # N
    # The engine's body: a cylinder from the nozzle (frame origin) along -z, the direction of
    # thrust [m]. 0: unknown (the retargeting then leaves the jet out of its clearance checks).
    length: float = 0.0
    radius: float = 0.0

    def __post_init__(self) -> None:
        check(self, RobotModelError, "> 0", "t_max")
        check(self, RobotModelError, ">= 0", "length", "radius")
        if (self.length > 0) != (self.radius > 0):
            raise RobotModelError(
                f"jet '{self.name}' needs both length and radius > 0 m, or neither"
            )


@dataclass(frozen=True)
class PdGain:
    joints: str  # fnmatch pattern
    kp: float
    kd: float

    def __post_init__(self) -> None:
        check(self, RobotModelError, "> 0", "kp")
        check(self, RobotModelError, ">= 0", "kd")


@dataclass(frozen=True)
class LimitDefaults:
    placeholder: float = 1000.0
    default_velocity: float = 7.64
    default_effort: float = 37.0

    def __post_init__(self) -> None:
        check(self, RobotModelError, "> 0", "placeholder", "default_velocity", "default_effort")


@dataclass(frozen=True)
class SimulationSpec:
    pd: tuple[PdGain, ...] = (PdGain("*", 100.0, 3.0),)
    armature: float = 0.05
    damping: float = 0.5
    timestep: float = 0.002
    friction: float = 1.0

    def __post_init__(self) -> None:
        check(self, RobotModelError, "non-empty", "pd")
        check(self, RobotModelError, ">= 0", "armature", "damping")
        check(self, RobotModelError, "> 0", "timestep", "friction")

    def gains(self, joint: str) -> tuple[float, float]:
        gain = next((g for g in self.pd if fnmatch.fnmatchcase(joint, g.joints)), None)
        if gain is None:
            raise RobotModelError(f"no PD gain pattern matches joint '{joint}'")
        return gain.kp, gain.kd


@dataclass(frozen=True)
class RobotSpec:
    name: str
    root: str
    forward: tuple[float, float, float]
    joints: tuple[str, ...]
    feet: tuple[FootSpec, ...]
    jets: tuple[JetSpec, ...]
    elbows: tuple[str, ...] = ()
    # Arm end effectors of the AMP features; the elbows when none are named.
    hands: tuple[str, ...] = ()
    # The standing posture: joint angles [rad]; joints not named stand at 0.
    posture: tuple[tuple[str, float], ...] = ()
    limits: LimitDefaults = LimitDefaults()
    simulation: SimulationSpec = SimulationSpec()
    source: str = "<memory>"

    def __post_init__(self) -> None:
        x, y, z = self.forward
        if not (z == 0 and abs(math.hypot(x, y) - 1) < 1e-6):  # NaN fails too
            expected = "a horizontal unit vector [x, y, 0]"
            raise refusal(RobotModelError, "forward", expected, self.forward)
        if not all(math.isfinite(angle) for _, angle in self.posture):
            raise refusal(RobotModelError, "posture", "finite angles [rad]", dict(self.posture))
        if not PLAIN_NAME.fullmatch(self.name):
            raise refusal(RobotModelError, "name", PLAIN_NAME_RULE, self.name)
        check(self, RobotModelError, "non-empty", "joints", "feet", "jets")
        check(self, RobotModelError, "distinct", "joints")

    @property
    def frames(self) -> tuple[str, ...]:
        """Every frame the spec names: root, soles, sole corners, elbows, hands, jets."""
        names = [self.root]
        for foot in self.feet:
            names += [foot.sole, *foot.corners]
        return (*names, *self.elbows, *self.hands, *(jet.frame for jet in self.jets))

    @property
    def end_effectors(self) -> tuple[str, ...]:
        """Frames whose positions relative to the base enter the AMP features: soles, hands."""
        return (*(foot.sole for foot in self.feet), *(self.hands or self.elbows))

    def posture_angles(self) -> dict[str, float]:
        angles = dict.fromkeys(self.joints, 0.0)
        angles.update(self.posture)
        return angles

    @classmethod
    def from_toml(cls, path: Path) -> RobotSpec:
        return cls.from_dict(read_toml(path, "robot spec", RobotModelError), str(path))

    @classmethod
    def builtin(cls, name: str = "ironcub") -> RobotSpec:
        text = resources.files("motionkit.robot").joinpath(f"{name}.toml").read_text()
        return cls.from_dict(tomllib.loads(text), f"motionkit/robot/{name}.toml")

    @classmethod
    def from_dict(cls, data: dict[str, Any], source: str) -> RobotSpec:
        """The spec of a TOML file's tables: [feet.SIDE] become FootSpecs, [posture] pairs."""
        data = dict(data)
        if isinstance(data.get("feet"), dict):
            feet = data["feet"].items()
            data["feet"] = [{"side": s, **f} if isinstance(f, dict) else f for s, f in feet]
        if isinstance(data.get("posture"), dict):
            data["posture"] = list(data["posture"].items())
        return load(cls, data, source, RobotModelError, source=source)
