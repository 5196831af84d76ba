"""Acclaim ASF (skeleton) and AMC (motion) reader.

A bone's rotation in rest-aligned frames is C M C^-1 (the Acclaim formula, column vectors): C
from the bone's `axis` angles and order, M from its dof values in their listed order (the first
listed is applied first, so "rx ry rz" gives M = Rz Ry Rx); the root uses `:root order` and its
`orientation`. A bone starts at its parent's end (end = start + rotated direction * length), so
the skeleton has a joint per bone at the bone's start, the root, and a "<bone>_end" joint at each
leaf bone's end. Root TX/TY/TZ are absolute (they replace `position`); a bone's tx/ty/tz move its
start along its axis frame and `l` lengthens it.

AMC frames must be numbered consecutively. A clip read in degrees whose every rotation value
(root and bones, all frames) stays within +-pi, while some reach RADIANS_HINT, is refused as
radians mislabelled: read as degrees it would be a body frozen within 3 degrees of its rest pose,
read as radians a motion of up to 180 degrees. One whose root turns further (a heading past pi)
but whose every joint (root aside) stays within +-2 pi is refused too when its root travels
GLIDE or more: read as degrees a figure would glide that far without turning a joint 6.3
degrees. Otherwise it is read, and `angle_unit_hint` names the likely cause when its
retargeting fails: joints within +-2 pi read as degrees, or beyond +-2 pi read as radians (a
full turn and more).
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from motionkit.core.errors import MocapError
from motionkit.files.inputs import read_text
from motionkit.mocap.naming import MappingSource
from motionkit.mocap.skeleton import (
    Y_UP_TO_Z_UP,
    Array,
    MocapClip,
    build_clip,
    clip_name,
    euler_matrix,
)

DEFAULT_RATE = 120.0  # Hz: CMU captures; AMC files store no rate
_DOFS = ("rx", "ry", "rz", "tx", "ty", "tz", "l")
_FRAME = re.compile(r"[0-9]+")
RADIANS_HINT = 0.2  # the largest rotation value of a clip that reads as radians (11 degrees)
GLIDE = 1.0  # m: a root that travels this far with no joint turned 2 pi degrees is misread


@dataclass
class Bone:
    """One ASF bone; angles in radians, lengths in file units."""

    name: str
    line: int
    direction: Array = field(default_factory=lambda: np.zeros(3))
    length: float = 0.0
    axis: Array = field(default_factory=lambda: np.zeros(3))
    axis_order: str = "xyz"
    dofs: tuple[str, ...] = ()


@dataclass
class Asf:
    """An ASF skeleton: bones in hierarchy order (parents first), their parents ("root" or a
    bone), the root's dof order, axis, position and orientation, and the units."""

    path: Path
    bones: dict[str, Bone]
    parent: dict[str, str]
    root_order: tuple[str, ...] = ("tx", "ty", "tz", "rx", "ry", "rz")
    root_axis_order: str = "xyz"
    root_position: Array = field(default_factory=lambda: np.zeros(3))
    root_orientation: Array = field(default_factory=lambda: np.zeros(3))
    length: float = 1.0  # `:units length`: 1 file unit = 0.0254 / length m
    degrees: bool = True

    @property
    def scale(self) -> float:
        return 0.0254 / self.length


def _floats(words: list[str], count: int, where: str) -> Array:
    try:
        values = [float(w) for w in words[:count]]
    except ValueError:
        raise MocapError(f"{where}: expected {count} numbers, got {' '.join(words)!r}") from None
    if len(values) != count:
        raise MocapError(f"{where}: expected {count} numbers, got {' '.join(words)!r}")
    if not all(map(math.isfinite, values)):
        raise MocapError(f"{where}: {' '.join(words[:count])!r} holds a non-finite number")
    return np.array(values)


def _order(word: str, where: str) -> str:
    order = word.lower()
    if sorted(order) != ["x", "y", "z"]:
        raise MocapError(f"{where}: axis order '{word}' is not a permutation of XYZ")
    return order


def read_asf(path: Path) -> Asf:
    """Parse an ASF file (see the module docstring)."""
    lines = read_text(path, MocapError, "the ASF skeleton").splitlines()
    asf = Asf(path, {}, {})
    section, bone = "", None
    hierarchy: list[tuple[int, list[str]]] = []
    for n, raw in enumerate(lines, 1):
        words = raw.split("#", 1)[0].split()
        if not words:
            continue
        where = f"{path} line {n}"
        key = words[0].lower()
        if key.startswith(":"):
            section = key
            words = words[1:]
            if not words:
                continue
            key = words[0].lower()
        if section == ":units" and key in ("length", "angle"):
            if key == "length":
                asf.length = float(_floats(words[1:], 1, where)[0])
                if not asf.length > 0:
                    raise MocapError(f"{where}: units length must be positive")
            else:
                if len(words) < 2 or words[1].lower() not in ("deg", "rad"):
                    raise MocapError(f"{where}: expected 'angle deg' or 'angle rad'")
                asf.degrees = words[1].lower() == "deg"
        elif section == ":root":
            _root_field(asf, key, words, where)
        elif section == ":bonedata":
            bone = _bone_field(asf, bone, key, words, n, where)
        elif section == ":hierarchy" and key not in ("begin", "end"):
            hierarchy.append((n, list(words)))
    if not asf.bones:
        raise MocapError(f"{path}: no :bonedata bones (not an ASF file?)")
    _link(asf, hierarchy)
    if asf.degrees:
        for b in asf.bones.values():
            b.axis = np.radians(b.axis)
        asf.root_orientation = np.radians(asf.root_orientation)
    return asf


def _root_field(asf: Asf, key: str, words: list[str], where: str) -> None:
    if key == "order":
        order = tuple(w.lower() for w in words[1:])
        if not order or any(w not in _DOFS[:6] for w in order) or len(set(order)) != len(order):
            raise MocapError(f"{where}: root order {' '.join(words[1:])!r} (expected TX..RZ)")
        asf.root_order = order
    elif key == "axis":
        asf.root_axis_order = _order(words[1] if len(words) > 1 else "", where)
    elif key == "position":
        asf.root_position = _floats(words[1:], 3, where)
    elif key == "orientation":
        asf.root_orientation = _floats(words[1:], 3, where)


def _bone_field(
    asf: Asf, bone: Bone | None, key: str, words: list[str], n: int, where: str
) -> Bone | None:
    if key == "begin":
        return Bone("", n)
    if bone is None:
        return None  # outside begin/end
    if key == "end":
        if not bone.name:
            raise MocapError(f"{asf.path} line {bone.line}: bone without a name")
        if bone.name in asf.bones or bone.name == "root":
            raise MocapError(f"{where}: duplicate bone '{bone.name}'")
        norm = np.linalg.norm(bone.direction)
        bone.direction = bone.direction / norm if norm > 0 else bone.direction
        asf.bones[bone.name] = bone
        return None
    if key == "name":
        bone.name = words[1] if len(words) > 1 else ""
    elif key == "direction":
        bone.direction = _floats(words[1:], 3, where)
    elif key == "length":
        bone.length = float(_floats(words[1:], 1, where)[0])
        if bone.length < 0:
            raise MocapError(f"{where}: bone '{bone.name}' has a negative length")
    elif key == "axis":
        bone.axis = _floats(words[1:], 3, where)
        bone.axis_order = _order(words[4] if len(words) > 4 else "xyz", where)
    elif key == "dof":
        dofs = tuple(w.lower() for w in words[1:])
        unknown = [w for w in dofs if w not in _DOFS]
        if unknown or len(set(dofs)) != len(dofs):
            raise MocapError(f"{where}: bone '{bone.name}' dof {' '.join(words[1:])!r}")
        bone.dofs = dofs
    return bone


def _link(asf: Asf, hierarchy: list[tuple[int, list[str]]]) -> None:
    """Fill asf.parent and reorder asf.bones parents-first from the :hierarchy lines."""
    children: dict[str, list[str]] = {}
    for n, (parent, *kids) in hierarchy:
        for name in [parent, *kids]:
            if name != "root" and name not in asf.bones:
                raise MocapError(f"{asf.path} line {n}: :hierarchy names unknown bone '{name}'")
        for kid in kids:
            if kid in asf.parent:
                raise MocapError(f"{asf.path} line {n}: bone '{kid}' has two parents")
            asf.parent[kid] = parent
        children.setdefault(parent, []).extend(kids)
    ordered, stack = [], list(reversed(children.get("root", [])))
    while stack:
        name = stack.pop()
        ordered.append(name)
        stack.extend(reversed(children.get(name, [])))
    orphans = [b for b in asf.bones if b not in ordered]
    if orphans:
        cycle = " (their parents form a cycle)" if all(b in asf.parent for b in orphans) else ""
        raise MocapError(
            f"{asf.path}: bones not reachable from root in :hierarchy: {orphans}{cycle}"
        )
    asf.bones = {name: asf.bones[name] for name in ordered}


def read_amc(path: Path, asf: Asf) -> tuple[Array, dict[str, Array], bool]:
    """Frame numbers (T,), the dof values (T, n) of the root and each moving bone, and
    whether they are in degrees."""
    lines = read_text(path, MocapError, "the AMC motion").splitlines()
    degrees = asf.degrees
    body = 0
    for n, line in enumerate(lines):
        word = line.strip().upper()
        if word.startswith("#") or not word:
            continue
        if word.startswith(":"):
            degrees = {":DEGREES": True, ":RADIANS": False}.get(word, degrees)
            continue
        body = n
        break
    else:
        raise MocapError(f"{path}: no frames")
    dofs = {"root": asf.root_order} | {b.name: b.dofs for b in asf.bones.values() if b.dofs}
    parsed = _fast_frames(lines, body, dofs)
    if parsed is None:
        parsed = _checked_frames(lines, body, dofs, path)
    numbers, values = parsed
    _check_numbers(numbers, path)
    _check_values(numbers, values, dofs, degrees, path, asf.scale)
    return numbers, values, degrees


def _check_numbers(numbers: Array, path: Path) -> None:
    """Frames numbered consecutively, or a MocapError naming the first that are not."""
    steps = np.diff(numbers)
    if np.all(steps == 1):
        return
    unique, counts = np.unique(numbers, return_counts=True)
    if counts.max() > 1:
        k = int(np.argmax(counts > 1))
        problem = f"frame {int(unique[k])} appears {counts[k]} times"
    elif np.any(steps < 0):
        k = int(np.argmax(steps < 0))
        problem = f"frame {int(numbers[k + 1])} comes after frame {int(numbers[k])} (out of order)"
    else:
        k = int(np.argmax(steps > 1))
        before, after = int(numbers[k]), int(numbers[k + 1])
        problem = f"frames {before + 1} to {after - 1} are missing (frame {after} follows {before})"
    raise MocapError(f"{path}: {problem}; AMC frames must be numbered consecutively")


def _rotations(
    values: dict[str, Array], dofs: dict[str, tuple[str, ...]], root: bool = True
) -> list[Array]:
    """The rotation values (T, n) of each bone (and the root, unless `root` is false)."""
    return [
        array[:, [d[0] == "r" for d in dofs[name]]]
        for name, array in values.items()
        if root or name != "root"
    ]


def angle_unit_hint(amc_path: Path, asf_path: Path) -> str:
    """The likely cause of a retargeting that failed, when the AMC's joint angles (its root
    aside) suggest the other angle unit than the one they are read in: all within +-2 pi (some
    reaching RADIANS_HINT) but read as degrees, or beyond +-2 pi but read as radians. A phrase
    naming the files' fix, or "" (also for files that do not read)."""
    try:
        asf = read_asf(asf_path)
        _, values, degrees = read_amc(amc_path, asf)
    except MocapError:
        return ""
    dofs = {"root": asf.root_order} | {b.name: b.dofs for b in asf.bones.values() if b.dofs}
    largest = _joints_largest(values, dofs)
    if degrees and RADIANS_HINT <= largest <= 2 * math.pi:
        return (
            f"{amc_path.name}'s angles look like radians read as degrees: its joint angles stay "
            f"within +-2 pi (largest {largest:.3f}), so no joint turns more than "
            f"{largest:.1f} degrees; add ':RADIANS' to the AMC header or set 'angle rad' in "
            f"{asf_path.name}'s :units"
        )
    if not degrees and largest > 2 * math.pi:
        return (
            f"{amc_path.name}'s angles look like degrees read as radians: joint angles reach "
            f"{largest:.1f}, beyond a full turn; remove ':RADIANS' from the AMC header or set "
            f"'angle deg' in {asf_path.name}'s :units"
        )
    return ""


def _joints_largest(values: dict[str, Array], dofs: dict[str, tuple[str, ...]]) -> float:
    """The largest rotation value of the bones (the root aside: its heading can be anything)."""
    joints = _rotations(values, dofs, root=False)
    return max((float(np.abs(a).max()) for a in joints if a.size), default=0.0)


def _travel(values: dict[str, Array], dofs: dict[str, tuple[str, ...]], scale: float) -> float:
    """How far the root moves over the floor [m]: the diagonal of the extent of its x and z
    (files are Y-up), in file units times `scale` (m per unit)."""
    columns = [dofs["root"].index(d) for d in ("tx", "tz") if d in dofs["root"]]
    if not columns:
        return 0.0
    return float(np.linalg.norm(np.ptp(values["root"][:, columns], axis=0))) * scale


def _check_values(
    numbers: Array,
    values: dict[str, Array],
    dofs: dict[str, tuple[str, ...]],
    degrees: bool,
    path: Path,
    scale: float,
) -> None:
    """Finite values, and no radians read as degrees (see the module docstring); `scale`: m
    per file unit."""
    for name, array in values.items():
        bad = np.argwhere(~np.isfinite(array))
        if len(bad):
            row, column = bad[0]
            raise MocapError(
                f"{path} frame {int(numbers[row])}: bone '{name}' {dofs[name][column]} is "
                f"{array[row, column]}, not a finite number"
            )
    if not degrees:
        return
    largest = max((float(np.abs(a).max()) for a in _rotations(values, dofs) if a.size), default=0.0)
    if RADIANS_HINT <= largest <= math.pi:
        raise MocapError(
            f"{path}: read in degrees, but every rotation value lies within +-pi (largest "
            f"{largest:.3f}): radians, it seems; add ':RADIANS' to the AMC header or set "
            "'angle rad' in the ASF's :units"
        )
    joints, travel = _joints_largest(values, dofs), _travel(values, dofs, scale)
    if RADIANS_HINT <= joints <= 2 * math.pi and travel >= GLIDE:
        raise MocapError(
            f"{path}: read in degrees, but no joint turns more than {joints:.1f} degrees "
            f"(every joint value within +-2 pi, largest {joints:.3f}) while the root travels "
            f"{travel:.1f} m: radians, it seems; add ':RADIANS' to the AMC header or set "
            "'angle rad' in the ASF's :units"
        )


def _fast_frames(
    lines: list[str], body: int, dofs: dict[str, tuple[str, ...]]
) -> tuple[Array, dict[str, Array]] | None:
    """Frames of a regular file (every frame lists the same bones in the same order, no
    comments), parsed column-wise with numpy; None when the file is not that regular."""
    end = len(lines)
    while end > body and not lines[end - 1].strip():
        end -= 1
    lines = lines[:end]
    size = len(dofs) + 1
    block = lines[body : body + size]
    names = [line.split(None, 1)[0] if line.strip() else "" for line in block[1:]]
    if sorted(names) != sorted(dofs) or (len(lines) - body) % size:
        return None
    heads = lines[body::size]
    if not all(_FRAME.fullmatch(h.strip()) for h in heads):
        return None
    values: dict[str, Array] = {}
    for k, name in enumerate(names, start=1):
        rows = lines[body + k :: size]
        cut = len(name)
        if not all(r.startswith(name) and r[cut : cut + 1].isspace() for r in rows):
            return None
        text = " ".join(r[cut:] for r in rows)
        try:
            flat = np.array(text.split(), dtype=np.float64)
        except ValueError:
            return None
        width = len(dofs[name])
        if flat.size != width * len(rows):
            return None
        values[name] = flat.reshape(len(rows), width)
    return np.array([int(h) for h in heads], dtype=float), values


def _checked_frames(
    lines: list[str], body: int, dofs: dict[str, tuple[str, ...]], path: Path
) -> tuple[Array, dict[str, Array]]:
    """Frames parsed line by line with a precise error for the first bad line."""
    numbers: list[int] = []
    rows: dict[str, list[list[float]]] = {name: [] for name in dofs}
    seen: set[str] = set()
    start = body + 1

    def close() -> None:
        for name in dofs:
            if name not in seen:
                raise MocapError(
                    f"{path} frame {numbers[-1]} (line {start}): bone '{name}' missing"
                )

    for n in range(body, len(lines)):
        words = lines[n].split("#", 1)[0].split()
        where = f"{path} line {n + 1}"
        if not words:
            continue
        if len(words) == 1 and _FRAME.fullmatch(words[0]):
            if numbers:
                close()
            numbers.append(int(words[0]))
            seen, start = set(), n + 1
            continue
        name, *text = words
        if not numbers:
            raise MocapError(f"{where}: expected a frame number, got {lines[n].strip()!r}")
        if name not in dofs:
            raise MocapError(f"{where}: bone '{name}' is not in the ASF (or has no dof)")
        if name in seen:
            raise MocapError(f"{where}: bone '{name}' twice in frame {numbers[-1]}")
        if len(text) != len(dofs[name]):
            raise MocapError(
                f"{where}: bone '{name}' has {len(text)} values, expected "
                f"{len(dofs[name])} ({' '.join(dofs[name])})"
            )
        try:
            rows[name].append([float(v) for v in text])
        except ValueError:
            raise MocapError(f"{where}: bone '{name}': unreadable number in {text}") from None
        seen.add(name)
    close()
    return np.array(numbers, dtype=float), {
        k: np.array(v).reshape(len(numbers), -1) for k, v in rows.items()
    }


def _dof_motion(
    dofs: tuple[str, ...], values: Array, axis: Array, axis_order: str, degrees: bool
) -> tuple[Array, Array, Array]:
    """Local rotation C M C^-1 (T, 3, 3) already turned Z-up, translation in the axis frame
    rotated to rest (T, 3, Y-up), and length change (T,) from one bone's dof values (T, n)."""
    frames = values.shape[0]
    c = euler_matrix(axis_order[::-1], axis[list("xyz".index(a) for a in axis_order[::-1])])
    rot_dofs = [i for i, d in enumerate(dofs) if d[0] == "r"]
    axes = "".join(dofs[i][1] for i in rot_dofs)
    angles = values[:, rot_dofs]
    if degrees:
        angles = np.radians(angles)
    m = euler_matrix(axes[::-1], angles[:, ::-1])
    shift = np.zeros((frames, 3))
    for i, d in enumerate(dofs):
        if d[0] == "t":
            shift[:, "xyz".index(d[1])] = values[:, i]
    length = values[:, dofs.index("l")] if "l" in dofs else np.zeros(frames)
    ac = Y_UP_TO_Z_UP @ c
    return ac @ m @ ac.T, shift @ c.T, length


def read_asf_amc(
    asf_path: Path,
    amc_path: Path,
    *,
    mapping: MappingSource = None,
    units: str | float | None = None,
    rate: float | None = None,
    keep_tpose: bool = False,
) -> MocapClip:
    """An ASF/AMC clip in metres, Z-up (see `motionkit.mocap.load_mocap`)."""
    asf = read_asf(asf_path)
    _, values, degrees = read_amc(amc_path, asf)
    frames = values["root"].shape[0]
    bones = list(asf.bones.values())
    leaves = [b for b in bones if b.name not in asf.parent.values()]
    names = ("root", *(b.name for b in bones), *(f"{b.name}_end" for b in leaves))
    index = {name: j for j, name in enumerate(names)}
    count = len(names)
    parents = [-1] + [index[asf.parent[b.name]] for b in bones] + [index[b.name] for b in leaves]
    vector = {b.name: b.direction * b.length for b in bones} | {"root": np.zeros(3)}
    offsets = np.zeros((count, 3))
    for b in bones:
        offsets[index[b.name]] = vector[asf.parent[b.name]]
    for b in leaves:
        offsets[index[f"{b.name}_end"]] = vector[b.name]

    rotations = np.broadcast_to(np.eye(3), (frames, count, 3, 3)).copy()
    local = np.broadcast_to(offsets, (frames, count, 3)).copy()
    moved = False
    root_rot, _, _ = _dof_motion(
        asf.root_order, values["root"], asf.root_orientation, asf.root_axis_order, degrees
    )
    rotations[:, 0] = root_rot
    root = np.broadcast_to(asf.root_position, (frames, 3)).copy()
    for i, d in enumerate(asf.root_order):
        if d[0] == "t":
            root[:, "xyz".index(d[1])] = values["root"][:, i]
    children = {b.name: [index[c] for c, p in asf.parent.items() if p == b.name] for b in bones}
    for b in bones:
        if b.name not in values:
            continue
        j = index[b.name]
        rotations[:, j], shift, grow = _dof_motion(
            b.dofs, values[b.name], b.axis, b.axis_order, degrees
        )
        if any(d[0] in "tl" for d in b.dofs):
            moved = True
            local[:, j] += shift
            ends = children[b.name] or [index[f"{b.name}_end"]]
            local[:, ends] += (grow[:, None] * b.direction)[:, None, :]
    return build_clip(
        name=clip_name(amc_path),
        source=amc_path,
        format="asf/amc",
        rate=DEFAULT_RATE if rate is None else rate,
        names=names,
        parents=tuple(parents),
        offsets=offsets,
        root=root,
        rotations=rotations,
        translations=local if moved else None,
        units=asf.scale if units is None else units,
        mapping=mapping,
        keep_tpose=keep_tpose,
    )


def find_asf(amc: Path) -> Path:
    """The skeleton of `amc`: <subject>.asf beside it (CMU "02_01.amc" -> "02.asf", also with
    a prefix such as "cmu_02.asf"), else the only .asf in its folder."""
    folder = amc.parent
    match = re.search(r"(?<![0-9])(\d+)_\d+(?![0-9])", amc.stem)
    tried = []
    if match:
        subject = match.group(1)
        for stem in (amc.stem[: match.start()] + subject, subject):
            candidate = folder / f"{stem}.asf"
            tried.append(candidate.name)
            if candidate.is_file():
                return candidate
    found = sorted(folder.glob("*.asf")) + sorted(folder.glob("*.ASF"))
    found = sorted(set(found))
    if len(found) == 1:
        return found[0]
    looked = f"looked for {' and '.join(tried)}; " if tried else ""
    raise MocapError(
        f"{amc}: no ASF skeleton found ({looked}{len(found)} .asf files in {folder}); pass asf="
    )
