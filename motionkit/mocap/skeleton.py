"""Skeleton, MocapClip and the shared kinematics: rotations, forward kinematics, units, T-pose.

Conventions: every local rotation is expressed in rest-aligned frames (identity = rest pose), so a
joint's world position is its parent's plus the parent's world rotation times its rest offset.
Clips are in metres and Z-up; readers hand `build_clip` file-unit, Y-up offsets and translations
(rotations already Z-up, built with `y_up_euler`).
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from functools import cached_property
from pathlib import Path
from typing import Literal

import numpy as np
import numpy.typing as npt

from motionkit.core.errors import MocapError
from motionkit.mocap import naming

Array = npt.NDArray[np.float64]

# Metres per file unit. "cmu": Acclaim length 0.45, 1 unit = 1/0.45 inch.
UNITS: dict[str, float] = {
    "m": 1.0,
    "cm": 0.01,
    "mm": 0.001,
    "inch": 0.0254,
    "cmu": 0.0254 / 0.45,
}
LEG_LENGTH = 0.85  # m, hip to ankle of an adult: the target of unit auto-detection
# Sanity bounds of a take: a rest-pose leg (hip-knee-ankle) in LEG_RANGE in the detected units
# (explicit units may make it any length up to MAX_EXTENT), no rest offset (bone) longer than
# MAX_BONE_LEGS legs, the root within MAX_EXTENT of the origin, a frame rate up to MAX_RATE.
# Files beyond them are broken or read in the wrong units.
LEG_RANGE = (0.1, 10.0)  # m
MAX_BONE_LEGS = 3.0
MAX_EXTENT = 10_000.0  # m
MAX_RATE = 10_000.0  # Hz

# +90 deg about x: x' = x, y' = -z, z' = y.
Y_UP_TO_Z_UP = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])


def axis_rotation(axis: str, angle: npt.ArrayLike, out: Array | None = None) -> Array:
    """Rotation matrices (..., 3, 3) by `angle` radians about "x", "y" or "z"."""
    angle = np.asarray(angle, dtype=float)
    i = "xyz".index(axis.lower())
    j, k = (i + 1) % 3, (i + 2) % 3
    c, s = np.cos(angle), np.sin(angle)
    r = np.zeros((*angle.shape, 3, 3)) if out is None else out
    if out is not None:
        r[...] = 0.0
    r[..., i, i] = 1.0
    r[..., j, j] = c
    r[..., k, k] = c
    r[..., k, j] = s
    r[..., j, k] = -s
    return r


def euler_matrix(axes: str, angles: npt.ArrayLike, out: Array | None = None) -> Array:
    """R = R_a0 @ R_a1 @ ... for axes like "zyx" and angles (..., len(axes)) in radians,
    written into `out` when given.

    This is BVH's channel order (the first listed rotation is the outermost). Acclaim lists
    rotations in the order they are applied, so its matrix is `euler_matrix(axes[::-1], ...)`.
    """
    angles = np.asarray(angles, dtype=float)
    if not axes:
        r = np.empty((*angles.shape[:-1], 3, 3)) if out is None else out
        r[...] = np.eye(3)
        return r
    r = axis_rotation(axes[0], angles[..., 0], out)
    for n, axis in enumerate(axes[1:], start=1):  # r @ R_axis mixes two columns of r
        i = "xyz".index(axis.lower())
        j, k = (i + 1) % 3, (i + 2) % 3
        c, s = np.cos(angles[..., n, None]), np.sin(angles[..., n, None])
        col_j, col_k = r[..., :, j].copy(), r[..., :, k].copy()
        r[..., :, j] = c * col_j + s * col_k
        r[..., :, k] = c * col_k - s * col_j
    return r


_Z_UP_AXIS = {"x": ("x", 1.0), "y": ("z", 1.0), "z": ("y", -1.0)}  # A R_axis(t) A^T


def y_up_euler(axes: str, angles: npt.ArrayLike, out: Array | None = None) -> Array:
    """A @ euler_matrix(axes, angles) @ A.T for A = Y_UP_TO_Z_UP: a Y-up file's rotation seen
    Z-up, computed directly (no pass over a large array)."""
    mapped = [_Z_UP_AXIS[a.lower()] for a in axes]
    signs = np.array([sign for _, sign in mapped])
    angles = np.asarray(angles, dtype=float) * signs
    return euler_matrix("".join(a for a, _ in mapped), angles, out)


def _read_only(a: Array) -> Array:
    a.flags.writeable = False
    return a


@dataclass(frozen=True, eq=False)
class Skeleton:
    """A joint tree: names, parents (-1 for the root, parents before children) and the rest
    offset (J, 3) of each joint in its parent's frame, metres, Z-up. offsets[0] is zero: the
    root's place over time is the clip's root_translation."""

    names: tuple[str, ...]
    parents: tuple[int, ...]
    offsets: Array

    def __post_init__(self) -> None:
        offsets = np.asarray(self.offsets, dtype=float)
        count = len(self.names)
        if len(self.parents) != count or offsets.shape != (count, 3):
            raise ValueError(
                f"skeleton: {count} names, {len(self.parents)} parents, offsets {offsets.shape}"
            )
        if count == 0 or self.parents[0] != -1:
            raise ValueError("skeleton: joint 0 must be the root (parent -1)")
        for j, p in enumerate(self.parents[1:], start=1):
            if not 0 <= p < j:
                raise ValueError(f"skeleton: joint '{self.names[j]}' has parent {p} (not before)")
        if len(set(self.names)) != count:
            raise ValueError("skeleton: joint names must be unique")
        object.__setattr__(self, "offsets", offsets)

    def __len__(self) -> int:
        return len(self.names)

    def index(self, name: str) -> int:
        """The index of joint `name`."""
        try:
            return self.names.index(name)
        except ValueError:
            raise KeyError(f"skeleton has no joint '{name}'") from None

    def rest_positions(self) -> Array:
        """Joint positions (J, 3) in the rest pose with the root at the origin."""
        pos = np.zeros((len(self), 3))
        for j, p in enumerate(self.parents[1:], start=1):
            pos[j] = pos[p] + self.offsets[j]
        return pos


def forward_kinematics(
    parents: tuple[int, ...], offsets: Array, root: Array, rotations: Array
) -> Array:
    """World joint positions (T, J, 3); offsets (J, 3) or per frame (T, J, 3), root (T, 3),
    local rotations (T, J, 3, 3). Vectorised over frames, one step per joint."""
    frames, count = rotations.shape[:2]
    has_children = {p for p in parents if p >= 0}
    world: dict[int, Array] = {0: np.ascontiguousarray(rotations[:, 0])}
    pos = np.empty((frames, count, 3))
    pos[:, 0] = root
    for j in range(1, count):
        p, w = parents[j], world[parents[j]]
        off = offsets[..., j, :]  # (3,) or (T, 3)
        pos[:, j] = pos[:, p] + sum(w[:, :, i] * off[..., i, None] for i in range(3))
        if j in has_children:
            world[j] = w @ np.ascontiguousarray(rotations[:, j])
    return pos


@dataclass(frozen=True, eq=False)
class MocapClip:
    """One mocap take in metres, Z-up: root translation and local joint rotations per frame.

    `translations`, when not None, holds per-frame local offsets (T, J, 3) that replace
    `skeleton.offsets` (files that animate joint translations: BVH position channels on non-root
    joints, ASF tx/ty/tz/l dofs). `landmark_map` names the joint behind each landmark; None means
    "resolve from the built-in name tables".
    """

    name: str
    source: Path
    format: Literal["bvh", "asf/amc"]
    rate: float
    skeleton: Skeleton
    root_translation: Array
    rotations: Array
    units_scale: float
    tpose_dropped: bool
    translations: Array | None = None
    landmark_map: Mapping[str, str] | None = field(default=None)

    def __post_init__(self) -> None:
        frames, count = self.rotations.shape[:2]
        if self.rotations.shape != (frames, count, 3, 3) or count != len(self.skeleton):
            raise ValueError(f"{self.source}: rotations {self.rotations.shape} for {count} joints")
        if self.root_translation.shape != (frames, 3):
            raise ValueError(f"{self.source}: root_translation {self.root_translation.shape}")
        if self.translations is not None and self.translations.shape != (frames, count, 3):
            raise ValueError(f"{self.source}: translations {self.translations.shape}")
        if not self.rate > 0:
            raise ValueError(f"{self.source}: rate {self.rate} Hz")

    @property
    def frames(self) -> int:
        return self.rotations.shape[0]

    @property
    def duration(self) -> float:
        """Seconds from the first to the last frame."""
        return max(self.frames - 1, 0) / self.rate

    @cached_property
    def _positions(self) -> Array:
        offsets = self.skeleton.offsets if self.translations is None else self.translations
        pos = forward_kinematics(
            self.skeleton.parents, offsets, self.root_translation, self.rotations
        )
        return _read_only(pos)

    def joint_positions(self) -> Array:
        """World positions (T, J, 3) of every joint, metres, Z-up (read-only, cached)."""
        return self._positions

    def landmarks(self) -> dict[str, Array]:
        """World positions (T, 3) of each of `LANDMARKS`; absent ones approximated (see naming)."""
        mapping = self.landmark_map
        if mapping is None:
            mapping = naming.resolve(self.skeleton.names, None, self.source)
        return naming.landmark_positions(self._positions, self.skeleton.names, mapping)


def leg_length(skeleton_rest: Array, names: tuple[str, ...], mapping: Mapping[str, str]) -> float:
    """The mean rest-pose leg length (hip-knee-ankle) in the skeleton's units."""
    lengths = []
    for side in "lr":
        chain = [names.index(mapping[f"{side}_{part}"]) for part in ("hip", "knee", "ankle")]
        pts = skeleton_rest[chain]
        lengths.append(np.linalg.norm(np.diff(pts, axis=0), axis=1).sum())
    return float(np.mean(lengths))


def units_from_leg(leg: float, source: Path) -> str:
    """The unit (key of UNITS) that makes a rest-pose leg (hip-knee-ankle) of `leg` file units
    closest to 0.85 m."""
    if not 0 < leg < math.inf:
        raise MocapError(
            f"{source}: cannot detect units: the rest-pose legs are {leg:g} file units long; "
            "pass units="
        )
    return min(UNITS, key=lambda unit: abs(math.log(leg * UNITS[unit] / LEG_LENGTH)))


def is_tpose(clip: MocapClip) -> bool:
    """Frame 0 is a calibration T-pose: near-zero rotations, both upper arms horizontal, and a
    pose clearly unlike frame 1 (which moves much more from frame 0 than frame 2 from frame 1)."""
    if clip.frames < 2:
        return False
    head = _frames(clip, slice(0, 3))
    rot = head.rotations[0, 1:]
    angles = np.arccos(np.clip((np.trace(rot, axis1=1, axis2=2) - 1) / 2, -1, 1))
    if np.median(angles) > math.radians(5):
        return False
    marks = head.landmarks()
    for side in "lr":
        arm = marks[f"{side}_elbow"][0] - marks[f"{side}_shoulder"][0]
        if abs(arm[2]) > math.sin(math.radians(20)) * np.linalg.norm(arm):
            return False
    local = np.stack([v - marks["pelvis"] for v in marks.values()], axis=1)  # (F, L, 3)
    jump = np.linalg.norm(local[1] - local[0], axis=1).max()
    if clip.frames == 2:
        return bool(jump > 0.05)
    step = np.linalg.norm(local[2] - local[1], axis=1).max()
    return bool(jump > 0.05 and jump > 5 * step)


def _frames(clip: MocapClip, frames: slice) -> MocapClip:
    trans = None if clip.translations is None else clip.translations[frames]
    return replace(
        clip,
        root_translation=clip.root_translation[frames],
        rotations=clip.rotations[frames],
        translations=trans,
    )


def build_clip(
    *,
    name: str,
    source: Path,
    format: Literal["bvh", "asf/amc"],
    rate: float,
    names: tuple[str, ...],
    parents: tuple[int, ...],
    offsets: Array,
    root: Array,
    rotations: Array,
    translations: Array | None,
    units: str | float | None,
    mapping: naming.MappingSource,
    keep_tpose: bool,
) -> MocapClip:
    """Finish a reader's output: resolve landmarks, choose units, turn offsets, root and
    translations (file units, Y-up) to Z-up metres, drop a leading T-pose unless `keep_tpose`,
    fold constant translations. `rotations` come Z-up already (see `y_up_euler`)."""
    if not 0 < rate <= MAX_RATE:
        raise MocapError(f"{source}: frame rate {rate} Hz (expected 0 to {MAX_RATE:g} Hz)")
    landmark_map = naming.resolve(names, mapping, source)
    with np.errstate(over="ignore", invalid="ignore"):  # huge values are refused below
        rest = Skeleton(names, parents, offsets).rest_positions()
        leg = leg_length(rest, names, landmark_map)
        scale = _unit_scale(units_from_leg(leg, source) if units is None else units, source)
        moves = {"root position": root * scale}
        if translations is not None:
            moves["a joint translation"] = translations * scale
        legs = LEG_RANGE if units is None else (0.0, MAX_EXTENT)
        _check_size(source, leg * scale, legs, names, offsets * scale, moves)

    a = Y_UP_TO_Z_UP
    offsets = offsets @ a.T * scale
    offsets[0] = 0.0
    root = root @ a.T * scale
    if translations is not None:
        translations = translations @ a.T * scale
        translations[:, 0] = 0.0  # the root's place is `root`
    clip = MocapClip(
        name,
        source,
        format,
        float(rate),
        Skeleton(names, parents, offsets),
        root,
        rotations,
        scale,
        False,
        translations,
        landmark_map,
    )
    if not keep_tpose and is_tpose(clip):
        clip = replace(_frames(clip, slice(1, None)), tpose_dropped=True)
    if clip.translations is not None and np.allclose(clip.translations, clip.translations[:1]):
        rest = Skeleton(names, parents, clip.translations[0].copy())
        clip = replace(clip, skeleton=rest, translations=None)
    return clip


def _check_size(
    source: Path,
    leg: float,
    legs: tuple[float, float],
    names: tuple[str, ...],
    offsets: Array,
    moves: dict[str, Array],
) -> None:
    """A MocapError unless the leg is within `legs` and the rest in proportion (see LEG_RANGE);
    all in metres."""
    low, high = legs
    if not (leg > 0 and low <= leg <= high):
        raise MocapError(
            f"{source}: the rest-pose leg is {leg:.3g} m long, not {low:g} to {high:g} m: "
            "wrong units (pass units=) or a broken skeleton"
        )
    bones = np.linalg.norm(offsets[1:], axis=1)
    if bones.size and not bones.max() <= MAX_BONE_LEGS * leg:
        joint = names[1 + int(np.argmax(bones))]
        raise MocapError(
            f"{source}: joint '{joint}' is {bones.max():.3g} m from its parent, over "
            f"{MAX_BONE_LEGS:g} leg lengths ({leg:.3g} m): a broken skeleton"
        )
    for what, values in moves.items():
        far = np.abs(values).reshape(len(values), -1).max(axis=1)
        if not far.max() <= MAX_EXTENT:
            raise MocapError(
                f"{source}: {what} of {far.max():.3g} m at frame {int(np.argmax(far))}, beyond "
                f"{MAX_EXTENT:g} m: a broken file or wrong units"
            )


def _unit_scale(units: str | float, source: Path) -> float:
    if isinstance(units, str):
        if units.lower() not in UNITS:
            raise MocapError(f"{source}: unknown units '{units}' (expected {', '.join(UNITS)})")
        return UNITS[units.lower()]
    scale = float(units)
    if not scale > 0:
        raise MocapError(f"{source}: units must be positive metres per file unit, got {units}")
    return scale


def clip_name(path: Path) -> str:
    """The clip id: a CMU "SS_TT" in the file name, else the file stem."""
    match = re.search(r"(?<![0-9])(\d+_\d+)(?![0-9])", path.stem)
    return match.group(1) if match else path.stem
