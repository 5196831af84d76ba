"""`Trajectory`: one motion clip of a robot, the type every stage writes and the trainer reads.

Conventions (also those of the MCAP files):
- time in seconds (float64), non-negative and strictly increasing;
- every other array float32, frame-major: row t is frame t;
- base_position in the world frame [m]; base_orientation a unit quaternion (w, x, y, z) of the
  base (root link) in the world;
- base_linear_velocity and base_angular_velocity both in the world frame [m/s, rad/s];
- joint arrays in `joint_names` order [rad, rad/s]; thrust [N] and throttle [%] in `jet_names`
  order; contacts (bool) in `foot_names` order;
- optional: contact_forces (frames, corners, 3) [N, world frame] in `corner_names` order (the
  robot's sole corners, see `corner_names(robot)`); landmarks (frames, L, 3) [m, world frame]: a
  skeleton in `landmark_names` order whose `landmark_parents` index an earlier landmark (-1: a
  root), e.g. the scaled human a clip was retargeted from.
"""

from __future__ import annotations

from dataclasses import dataclass, field, fields, replace
from typing import Any

import numpy as np

from motionkit import __version__
from motionkit.core.errors import DatasetError

KINDS = ("walk", "run", "stand", "takeoff", "flight", "landing", "jump", "rollout", "other")
GENERATORS = ("retarget", "trajopt", "rollout", "synthetic", "import")


@dataclass(frozen=True)
class Source:
    """Where the motion came from."""

    file: str = ""
    clip: str = ""
    licence: str = ""
    acknowledgement: str = ""


@dataclass(frozen=True)
class Metadata:
    """What a clip is and how it was made; written to the MCAP metadata record."""

    robot: str
    robot_hash: str
    kind: str
    generator: str
    source: Source = Source()
    config: dict[str, Any] = field(default_factory=dict)  # the generator's resolved config
    metrics: dict[str, Any] = field(default_factory=dict)  # quality figures of the generator
    motionkit_version: str = __version__

    def __post_init__(self) -> None:
        if self.kind not in KINDS:
            raise DatasetError(f"metadata kind {self.kind!r} is not one of {', '.join(KINDS)}")
        if self.generator not in GENERATORS:
            raise DatasetError(
                f"metadata generator {self.generator!r} is not one of {', '.join(GENERATORS)}"
            )


# (field, dtype, shape of one frame): each entry an int or the name of a names field
_ARRAYS: tuple[tuple[str, str, tuple[int | str, ...]], ...] = (
    ("time", "float64", ()),
    ("base_position", "float32", (3,)),
    ("base_orientation", "float32", (4,)),
    ("joint_positions", "float32", ("joint_names",)),
    ("joint_velocities", "float32", ("joint_names",)),
    ("base_linear_velocity", "float32", (3,)),
    ("base_angular_velocity", "float32", (3,)),
    ("thrust", "float32", ("jet_names",)),
    ("throttle", "float32", ("jet_names",)),
    ("contacts", "bool", ("foot_names",)),
    ("contact_forces", "float32", ("corner_names", 3)),
    ("landmarks", "float32", ("landmark_names", 3)),
)
ARRAY_FIELDS = tuple(name for name, _, _ in _ARRAYS)
FRAME_SHAPES = {name: shape for name, _, shape in _ARRAYS}
# optional arrays (None when absent) and the names that label them
OPTIONAL = {"throttle": None, "contact_forces": "corner_names", "landmarks": "landmark_names"}
NAME_FIELDS = ("joint_names", "jet_names", "foot_names", "corner_names", "landmark_names")


def frame_shape(name: str, names: dict[str, tuple[str, ...]]) -> tuple[int, ...]:
    """The shape of one frame of array `name`, given the names fields."""
    return tuple(len(names[w]) if isinstance(w, str) else w for w in FRAME_SHAPES[name])


@dataclass(frozen=True, eq=False)
class Trajectory:
    time: np.ndarray
    base_position: np.ndarray
    base_orientation: np.ndarray
    joint_names: tuple[str, ...]
    joint_positions: np.ndarray
    joint_velocities: np.ndarray
    base_linear_velocity: np.ndarray
    base_angular_velocity: np.ndarray
    thrust: np.ndarray
    contacts: np.ndarray
    metadata: Metadata
    jet_names: tuple[str, ...] = ()
    foot_names: tuple[str, ...] = ()
    throttle: np.ndarray | None = None
    corner_names: tuple[str, ...] = ()
    contact_forces: np.ndarray | None = None  # (frames, corners, 3) [N], world frame
    landmark_names: tuple[str, ...] = ()
    landmark_parents: tuple[int, ...] = ()  # index of each landmark's parent, -1 for a root
    landmarks: np.ndarray | None = None  # (frames, landmarks, 3) [m], world frame

    def __post_init__(self) -> None:
        for names in NAME_FIELDS:
            object.__setattr__(self, names, tuple(getattr(self, names)))
        object.__setattr__(self, "landmark_parents", tuple(map(int, self.landmark_parents)))
        count = np.shape(self.time)[0] if np.ndim(self.time) == 1 else -1
        if count < 1:
            raise DatasetError(f"time should be a 1-D array of frames, got {np.shape(self.time)}")
        names = {name: getattr(self, name) for name in NAME_FIELDS}
        for name, dtype, _ in _ARRAYS:
            value = getattr(self, name)
            if value is None:
                continue
            array = np.ascontiguousarray(value, dtype=dtype)
            expected = (count, *frame_shape(name, names))
            if array.shape != expected:
                raise DatasetError(f"{name} has shape {array.shape}, expected {expected}")
            array.setflags(write=False)
            object.__setattr__(self, name, array)
        self._check_labels()

    def _check_labels(self) -> None:
        """Names of optional arrays only with their array; unique names; parents first."""
        for array, names in OPTIONAL.items():
            if names is not None and getattr(self, array) is None and getattr(self, names):
                raise DatasetError(f"{names} given without {array}")
            labels = getattr(self, names) if names else ()
            if len(set(labels)) != len(labels):
                raise DatasetError(f"{names} {list(labels)} repeat a name")
        parents = self.landmark_parents
        if len(parents) != len(self.landmark_names):
            raise DatasetError(
                f"landmark_parents has {len(parents)} entries, expected one per landmark "
                f"({len(self.landmark_names)})"
            )
        for i, parent in enumerate(parents):
            if not -1 <= parent < i:
                raise DatasetError(
                    f"landmark_parents[{i}] = {parent} ({self.landmark_names[i]}): expected -1 "
                    f"(a root) or the index of an earlier landmark (parents come first)"
                )

    @property
    def frames(self) -> int:
        return len(self.time)

    @property
    def duration(self) -> float:
        return float(self.time[-1] - self.time[0])

    @property
    def rate(self) -> float:
        """Frames per second (the median step); 0 for a single frame."""
        return float(1.0 / np.median(np.diff(self.time))) if self.frames > 1 else 0.0

    def arrays(self) -> dict[str, np.ndarray]:
        """The per-frame arrays keyed by field name (optional ones only when present)."""
        out = {name: getattr(self, name) for name in ARRAY_FIELDS}
        return {name: value for name, value in out.items() if value is not None}

    def select(self, frames: slice | np.ndarray) -> Trajectory:
        """The same clip restricted to some frames (a slice or an index array)."""
        return replace(self, **{k: v[frames] for k, v in self.arrays().items()})

    def window(self, start: float | None = None, end: float | None = None) -> Trajectory:
        """Frames with start <= time <= end."""
        lo = 0 if start is None else int(np.searchsorted(self.time, start, "left"))
        hi = self.frames if end is None else int(np.searchsorted(self.time, end, "right"))
        if hi <= lo:
            raise DatasetError(
                f"no frame in the window [{start}, {end}] s of a clip spanning "
                f"[{self.time[0]:.3f}, {self.time[-1]:.3f}] s"
            )
        return self.select(slice(lo, hi))

    def equals(self, other: Trajectory) -> bool:
        """Identical arrays (bit for bit), names and metadata."""
        mine, theirs = self.arrays(), other.arrays()
        if mine.keys() != theirs.keys():
            return False
        same_arrays = all(np.array_equal(mine[name], theirs[name]) for name in mine)
        same_rest = all(
            getattr(self, f.name) == getattr(other, f.name)
            for f in fields(self)
            if f.name not in ARRAY_FIELDS
        )
        return same_arrays and same_rest
