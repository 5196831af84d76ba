"""The robot spec: what a robot must declare for motionkit (a TOML file beside its URDF).

Joint order, feet and sole corners, jets and their thrust limits, the arm end effectors, the
facing direction of the base, limit defaults and simulation settings. The built-in iRonCub spec
is `ironcub.toml` in this folder; a user robot passes its own with `--spec`.
"""

from __future__ import annotations

import fnmatch
import tomllib
from dataclasses import dataclass
from importlib import resources
from pathlib import Path
from typing import Any

from motionkit.errors import RobotModelError
from motionkit.tomlfile import read_toml

# Thrust acts along this axis of every jet frame (the frame origin is at the nozzle).
THRUST_AXIS = (0.0, 0.0, -1.0)


@dataclass(frozen=True)
class FootSpec:
    side: str
    sole: str
    corners: tuple[str, ...]


@dataclass(frozen=True)
class JetSpec:
    name: str
    frame: str
    t_max: float  # N
    # The engine's body: a cylinder from the nozzle (frame origin) along -z, the direction of
    # thrust [m]. 0: unknown (the retargeting then leaves the jet out of its clearance checks).
    length: float = 0.0
    radius: float = 0.0


@dataclass(frozen=True)
class PdGain:
    joints: str  # fnmatch pattern
    kp: float
    kd: float


PD_FIELDS = (("joints", str), ("kp", float), ("kd", float))
JET_SIZES = ("length", "radius")  # optional keys of a [[jets]] entry


@dataclass(frozen=True)
class LimitDefaults:
    placeholder: float = 1000.0
    default_velocity: float = 7.64
    default_effort: float = 37.0


@dataclass(frozen=True)
class SimulationSpec:
    pd: tuple[PdGain, ...] = (PdGain("*", 100.0, 3.0),)
    armature: float = 0.05
    damping: float = 0.5
    timestep: float = 0.002
    friction: float = 1.0

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
        def need(table: dict[str, Any], key: str, kind: type, where: str) -> Any:
            if key not in table:
                raise RobotModelError(f"{source}: missing '{where}{key}'")
            value = table[key]
            if kind is float and isinstance(value, int):
                value = float(value)
            if not isinstance(value, kind):
                raise RobotModelError(
                    f"{source}: '{where}{key}' should be a {kind.__name__}, got {value!r}"
                )
            return value

        forward = need(data, "forward", list, "")
        if len(forward) != 3:
            raise RobotModelError(f"{source}: 'forward' should be 3 numbers, got {forward}")
        feet_table = need(data, "feet", dict, "")
        feet = tuple(
            FootSpec(
                side,
                need(foot, "sole", str, f"feet.{side}."),
                tuple(need(foot, "corners", list, f"feet.{side}.")),
            )
            for side, foot in feet_table.items()
        )
        jets = tuple(
            JetSpec(
                need(jet, "name", str, f"jets[{i}]."),
                need(jet, "frame", str, f"jets[{i}]."),
                need(jet, "t_max", float, f"jets[{i}]."),
                *(need(jet, key, float, f"jets[{i}].") if key in jet else 0.0 for key in JET_SIZES),
            )
            for i, jet in enumerate(data.get("jets", []))
        )
        for jet in jets:
            if jet.t_max <= 0:
                raise RobotModelError(f"{source}: jet '{jet.name}' needs t_max > 0 N")
            if min(jet.length, jet.radius) < 0 or (jet.length > 0) != (jet.radius > 0):
                raise RobotModelError(
                    f"{source}: jet '{jet.name}' needs both length and radius > 0 m, or neither"
                )
        sim = data.get("simulation", {})
        pd = tuple(
            PdGain(*(need(g, k, t, f"simulation.pd[{i}].") for k, t in PD_FIELDS))
            for i, g in enumerate(sim.get("pd", []))
        )
        simulation = _table(
            SimulationSpec,
            {k: float(v) for k, v in sim.items() if k != "pd"} | ({"pd": pd} if pd else {}),
            f"{source}: [simulation]",
        )
        return cls(
            name=need(data, "name", str, ""),
            root=need(data, "root", str, ""),
            forward=tuple(float(v) for v in forward),  # type: ignore[arg-type]
            joints=tuple(need(data, "joints", list, "")),
            feet=feet,
            jets=jets,
            elbows=tuple(data.get("elbows", [])),
            hands=tuple(data.get("hands", [])),
            posture=tuple((k, float(v)) for k, v in data.get("posture", {}).items()),
            limits=_table(
                LimitDefaults,
                {k: float(v) for k, v in data.get("limits", {}).items()},
                f"{source}: [limits]",
            ),
            simulation=simulation,
            source=source,
        )


def _table(cls: type, values: dict[str, Any], where: str) -> Any:
    known = set(cls.__dataclass_fields__)
    unknown = sorted(set(values) - known)
    if unknown:
        raise RobotModelError(f"{where} has unknown keys {unknown}; known: {sorted(known)}")
    return cls(**values)
