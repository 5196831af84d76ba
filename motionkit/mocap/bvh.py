"""BVH reader: HIERARCHY by recursive descent, MOTION with numpy.

Channels come in any order on any joint. Rotation channels listed "Z Y X" give R = Rz Ry Rx
(degrees). Position channels replace the joint's OFFSET along their axis; on the root they are
the root translation. End Sites become leaf joints named "<parent>_End".
"""

from __future__ import annotations

import io
import math
import re
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from motionkit.core.errors import MocapError
from motionkit.files.inputs import read_text
from motionkit.mocap.naming import MappingSource
from motionkit.mocap.skeleton import (
    MAX_RATE,
    Array,
    MocapClip,
    build_clip,
    clip_name,
    y_up_euler,
)

_CHANNELS = {f"{a}{kind}": (kind, a) for a in "xyz" for kind in ("position", "rotation")}
MAX_DEPTH = 200  # joints nested deeper than this are refused (a human chain is under 30)


@dataclass
class _Joint:
    name: str
    parent: int
    line: int
    offset: tuple[float, ...] = (0.0, 0.0, 0.0)
    channels: list[tuple[str, str]] = field(default_factory=list)  # (kind, axis)


class _Tokens:
    """The HIERARCHY's tokens with their line numbers."""

    def __init__(self, lines: list[str], path: Path) -> None:
        self.items = [(tok, n) for n, line in enumerate(lines, 1) for tok in line.split()]
        self.pos = 0
        self.path = path

    def error(self, message: str, line: int | None = None) -> MocapError:
        if line is None:
            line = self.items[min(self.pos, len(self.items) - 1)][1] if self.items else 1
        return MocapError(f"{self.path} line {line}: {message}")

    def next(self, what: str) -> tuple[str, int]:
        if self.pos >= len(self.items):
            raise self.error(f"HIERARCHY ends early: expected {what}")
        self.pos += 1
        return self.items[self.pos - 1]

    def expect(self, word: str) -> int:
        tok, line = self.next(f"'{word}'")
        if tok.lower() != word.lower():
            raise self.error(f"expected '{word}', got '{tok}'", line)
        return line

    def rest_of_line(self, line: int) -> str:
        """The tokens left on `line` before a '{' (a joint name)."""
        words = []
        while self.pos < len(self.items) and self.items[self.pos][1] == line:
            if self.items[self.pos][0] == "{":
                break
            words.append(self.next("a name")[0])
        return " ".join(words)

    def number(self, what: str) -> float:
        tok, line = self.next(what)
        try:
            value = float(tok)
        except ValueError:
            raise self.error(f"expected {what}, got '{tok}'", line) from None
        if not math.isfinite(value):
            raise self.error(f"{what} '{tok}' is not a finite number", line)
        return value


def _parse_hierarchy(tokens: _Tokens) -> list[_Joint]:
    tokens.expect("HIERARCHY")
    tokens.expect("ROOT")
    joints: list[_Joint] = []
    _parse_joint(tokens, joints, parent=-1, line=tokens.items[tokens.pos - 1][1], depth=0)
    if tokens.pos < len(tokens.items):
        tok, line = tokens.items[tokens.pos]
        raise tokens.error(f"expected MOTION after the ROOT joint, got '{tok}'", line)
    return joints


def _parse_joint(tokens: _Tokens, joints: list[_Joint], parent: int, line: int, depth: int) -> None:
    name = tokens.rest_of_line(line)
    if not name:
        raise tokens.error("joint without a name", line)
    if depth > MAX_DEPTH:
        raise tokens.error(f"joint '{name}' is nested over {MAX_DEPTH} joints deep", line)
    if any(j.name == name for j in joints):
        raise tokens.error(f"duplicate joint name '{name}'", line)
    joint = _Joint(name, parent, line)
    index = len(joints)
    joints.append(joint)
    tokens.expect("{")
    has_offset = False
    while True:
        tok, at = tokens.next(f"'}}' closing joint '{name}' (opened at line {line})")
        word = tok.upper()
        if word == "OFFSET":
            joint.offset = tuple(tokens.number("an OFFSET value") for _ in range(3))
            has_offset = True
        elif word == "CHANNELS":
            if joint.channels:
                raise tokens.error(f"joint '{name}' has a second CHANNELS line", at)
            count = tokens.number("the channel count")
            if count != int(count) or not 0 <= count <= len(_CHANNELS):
                raise tokens.error(f"bad channel count {count:g} (0 to {len(_CHANNELS)})", at)
            for _ in range(int(count)):
                channel, cline = tokens.next("a channel name")
                if channel.lower() not in _CHANNELS:
                    raise tokens.error(
                        f"unknown channel '{channel}' of joint '{name}' "
                        "(expected X/Y/Z + position/rotation)",
                        cline,
                    )
                if _CHANNELS[channel.lower()] in joint.channels:
                    raise tokens.error(f"channel '{channel}' twice in joint '{name}'", cline)
                joint.channels.append(_CHANNELS[channel.lower()])
        elif word == "JOINT":
            _parse_joint(tokens, joints, index, at, depth + 1)
        elif word == "END":
            tokens.expect("Site")
            tokens.rest_of_line(at)
            tokens.expect("{")
            tokens.expect("OFFSET")
            offset = tuple(tokens.number("an OFFSET value") for _ in range(3))
            tokens.expect("}")
            end = f"{name}_End"
            while any(j.name == end for j in joints):
                end += "_"
            joints.append(_Joint(end, index, at, offset))
        elif tok == "}":
            break
        else:
            raise tokens.error(f"unexpected '{tok}' in joint '{name}'", at)
    if not has_offset:
        raise tokens.error(f"joint '{name}' has no OFFSET", line)


def _split_motion(text: str, path: Path) -> tuple[list[str], int, float, str, int]:
    """HIERARCHY lines, declared frame count, frame time, motion text, its first line number."""
    match = re.search(r"^[ \t]*MOTION[ \t]*\r?$", text, flags=re.MULTILINE | re.IGNORECASE)
    if match is None:
        raise MocapError(f"{path}: no MOTION section (not a BVH file, or truncated)")
    head = text[: match.start()].splitlines()
    rest = text[match.end() :].split("\n", 3)
    first = len(head) + 2  # line number of "Frames:"
    values: list[float] = []
    for n, key in enumerate(("Frames:", "Frame Time:")):
        line = rest[n + 1] if len(rest) > n + 1 else ""
        m = re.fullmatch(rf"\s*{key}\s*(\S+)\s*", line, flags=re.IGNORECASE)
        try:
            value = float(m.group(1)) if m else float("nan")
        except ValueError:
            value = float("nan")
        if not 0 <= value < math.inf or (n == 0 and value != int(value)):
            raise MocapError(f"{path} line {first + n}: expected '{key} <number>', got {line!r}")
        values.append(value)
    motion = rest[3] if len(rest) > 3 else ""
    return head, int(values[0]), values[1], motion, first + 2


def _parse_motion(motion: str, frames: int, columns: int, first_line: int, path: Path) -> Array:
    """(frames, columns) values; any mismatch names the line."""
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            data = np.loadtxt(io.StringIO(motion), ndmin=2, dtype=np.float64)
        good = data.shape[1] == columns if data.size else True
    except ValueError:
        good = False
    if not good:
        _diagnose(motion, columns, first_line, path)
        raise MocapError(f"{path}: unreadable MOTION data")  # _diagnose found nothing
    if data.shape[0] < frames:
        end = first_line + len(motion.splitlines())
        raise MocapError(
            f"{path} line {end}: truncated: motion ends after {data.shape[0]} frames, "
            f"'Frames: {frames}' declared"
        )
    if data.shape[0] > frames:
        extra = _data_lines(motion)[frames]
        raise MocapError(
            f"{path} line {first_line + extra}: more motion lines than 'Frames: {frames}'"
        )
    bad = np.argwhere(~np.isfinite(data))
    if len(bad):
        row, column = bad[0]
        raise MocapError(
            f"{path} line {first_line + _data_lines(motion)[row]}: value {column + 1} "
            f"({data[row, column]}) is not a finite number"
        )
    return data


def _data_lines(motion: str) -> list[int]:
    return [n for n, line in enumerate(motion.splitlines()) if line.strip()]


def _diagnose(motion: str, columns: int, first_line: int, path: Path) -> None:
    """Raise a MocapError at the first bad motion line (slow path, only for broken files)."""
    lines = motion.splitlines()
    for n in _data_lines(motion):
        values = lines[n].split()
        where = f"{path} line {first_line + n}"
        if len(values) != columns:
            last = n == len(lines) - 1
            cut = " (file truncated?)" if last and len(values) < columns else ""
            raise MocapError(f"{where}: {len(values)} values, expected {columns}{cut}")
        for column, value in enumerate(values):
            try:
                float(value)
            except ValueError:
                raise MocapError(f"{where}: value {column + 1} {value!r} is not a number") from None


def read_bvh(
    path: Path,
    *,
    mapping: MappingSource = None,
    units: str | float | None = None,
    rate: float | None = None,
    keep_tpose: bool = False,
) -> MocapClip:
    """A BVH clip in metres, Z-up (see `motionkit.mocap.load_mocap`)."""
    text = read_text(path, MocapError, "the BVH file")
    head, frames, frame_time, motion, first_line = _split_motion(text, path)
    joints = _parse_hierarchy(_Tokens(head, path))
    columns = sum(len(j.channels) for j in joints)
    if columns == 0:
        raise MocapError(f"{path}: no joint has CHANNELS: the file animates nothing")
    data = _parse_motion(motion, frames, columns, first_line, path)
    if frames == 0:
        raise MocapError(f"{path}: 'Frames: 0': the clip has no motion")
    if rate is None:
        if not frame_time >= 1 / MAX_RATE:
            raise MocapError(
                f"{path}: 'Frame Time: {frame_time}': expected at least {1 / MAX_RATE:g} s "
                "(or pass rate=)"
            )
        rate = 1.0 / frame_time
        if abs(rate - round(rate)) < 1e-4 * rate:  # ".0083333" means 120 Hz
            rate = float(round(rate))

    count = len(joints)
    offsets = np.array([j.offset for j in joints], dtype=float)
    rotations = np.empty((frames, count, 3, 3))
    local = None  # per-frame offsets, only when non-root joints have position channels
    if any(kind == "position" for j in joints[1:] for kind, _ in j.channels):
        local = np.broadcast_to(offsets, (frames, count, 3)).copy()
    root = np.broadcast_to(offsets[0], (frames, 3)).copy()
    column = 0
    for j, joint in enumerate(joints):
        axes = "".join(axis for kind, axis in joint.channels if kind == "rotation")
        cols = [column + i for i, (kind, _) in enumerate(joint.channels) if kind == "rotation"]
        y_up_euler(axes, np.radians(data[:, cols]), out=rotations[:, j])
        for i, (kind, axis) in enumerate(joint.channels):
            if kind == "position" and j == 0:
                root[:, "xyz".index(axis)] = data[:, column + i]
            elif kind == "position" and local is not None:
                local[:, j, "xyz".index(axis)] = data[:, column + i]
        column += len(joint.channels)
    return build_clip(
        name=clip_name(path),
        source=path,
        format="bvh",
        rate=rate,
        names=tuple(j.name for j in joints),
        parents=tuple(j.parent for j in joints),
        offsets=offsets,
        root=root,
        rotations=rotations,
        translations=local,
        units=units,
        mapping=mapping,
        keep_tpose=keep_tpose,
    )
