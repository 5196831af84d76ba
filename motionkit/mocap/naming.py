"""Landmarks: which skeleton joint is the left knee, the neck... for each naming convention.

Built-in tables cover CMU ASF bone names and the BVH conventions CMU conversions circulate with.
Names compare case-, underscore- and namespace-insensitively ("mixamorig:Left_Up_Leg" matches
"LeftUpLeg"); BVH End Sites are joints named "<parent>_End". A user mapping (TOML
`[landmarks] l_knee = "LeftLeg"`, or a dict) overrides the tables.

Landmarks a skeleton may lack are approximated from neighbours:
pelvis = hip midpoint; neck = shoulder midpoint; chest = spine-neck midpoint (without a spine:
2/3 of the way pelvis -> neck); spine = pelvis-chest midpoint (without a chest: 1/3 pelvis -> neck).

PARENTS joins the landmarks into a tree (to draw the skeleton); `skeleton(names)` gives the parent
indices of a subset.
"""

from __future__ import annotations

import re
import tomllib
from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np
import numpy.typing as npt

from motionkit.core.errors import MocapError
from motionkit.files.inputs import read_text

LANDMARKS: tuple[str, ...] = (
    "pelvis",
    "l_hip",
    "l_knee",
    "l_ankle",
    "l_toe",
    "r_hip",
    "r_knee",
    "r_ankle",
    "r_toe",
    "spine",
    "chest",
    "neck",
    "head",
    "l_shoulder",
    "l_elbow",
    "l_wrist",
    "r_shoulder",
    "r_elbow",
    "r_wrist",
)
# The landmarks as a tree (parents before children): legs from the pelvis, arms from the neck.
PARENTS: dict[str, str | None] = {
    "pelvis": None,
    "l_hip": "pelvis",
    "l_knee": "l_hip",
    "l_ankle": "l_knee",
    "l_toe": "l_ankle",
    "r_hip": "pelvis",
    "r_knee": "r_hip",
    "r_ankle": "r_knee",
    "r_toe": "r_ankle",
    "spine": "pelvis",
    "chest": "spine",
    "neck": "chest",
    "head": "neck",
    "l_shoulder": "neck",
    "l_elbow": "l_shoulder",
    "l_wrist": "l_elbow",
    "r_shoulder": "neck",
    "r_elbow": "r_shoulder",
    "r_wrist": "r_elbow",
}
APPROXIMATED = ("pelvis", "spine", "chest", "neck")
REQUIRED = tuple(k for k in LANDMARKS if k not in APPROXIMATED)

DESCRIPTIONS = {
    "pelvis": "root / centre of the hips (optional)",
    "hip": "thigh joint: femur, proximal end",
    "knee": "knee: shin, proximal end",
    "ankle": "ankle: foot, proximal end",
    "toe": "ball of the foot / toe base",
    "spine": "lower back (optional)",
    "chest": "upper back / thorax (optional)",
    "neck": "base of the neck (optional)",
    "head": "top or centre of the head",
    "shoulder": "upper arm, proximal end",
    "elbow": "forearm, proximal end",
    "wrist": "hand, proximal end",
}

_SIDED = ("hip", "knee", "ankle", "toe", "shoulder", "elbow", "wrist")

# Candidates per landmark, first present wins; {Side} = Left/Right, {S} = L/R, {s} = l/r.
_TABLE_TEMPLATES: dict[str, dict[str, tuple[str, ...]]] = {
    "cmu_asf": {  # CMU Acclaim bones: joints at bone starts, "<bone>_end" at leaf ends
        "pelvis": ("root",),
        "hip": ("{s}femur",),
        "knee": ("{s}tibia",),
        "ankle": ("{s}foot",),
        "toe": ("{s}toes", "{s}foot_end"),
        "spine": ("upperback",),
        "chest": ("thorax",),
        "neck": ("lowerneck",),
        "head": ("head_end", "head"),
        "shoulder": ("{s}humerus",),
        "elbow": ("{s}radius",),
        "wrist": ("{s}wrist",),
    },
    "cmu_bvh": {  # CMU BVH conversions (LeftUpLeg/LeftLeg, LeftShoulder = clavicle), Mixamo
        "pelvis": ("Hips", "Hip", "Pelvis"),
        "hip": ("{Side}UpLeg",),
        "knee": ("{Side}Leg",),
        "ankle": ("{Side}Foot",),
        "toe": ("{Side}ToeBase", "{Side}Toe", "{Side}Foot_End"),
        "spine": ("Spine",),
        "chest": ("Spine2", "Spine1", "Chest"),
        "neck": ("Neck",),
        "head": ("Head_End", "HeadTop_End", "Head"),
        "shoulder": ("{Side}Arm",),
        "elbow": ("{Side}ForeArm",),
        "wrist": ("{Side}Hand",),
    },
    "biovision": {  # LeftHip/LeftKnee/LeftAnkle, LeftCollar/LeftShoulder or LeftUpArm/LeftLowArm
        "pelvis": ("Hips", "Hip", "Pelvis", "Root"),
        "hip": ("{Side}Hip", "{S}Hip", "{Side}UpLeg", "{Side}Thigh"),
        "knee": ("{Side}Knee", "{S}Knee", "{Side}LowLeg", "{Side}Shin"),
        "ankle": ("{Side}Ankle", "{S}Ankle", "{Side}Foot"),
        "toe": (
            "{Side}Toe",
            "{Side}Toes",
            "{Side}ToeBase",
            "{S}Toe",
            "{Side}Ankle_End",
            "{S}Ankle_End",
            "{Side}Foot_End",
        ),
        "spine": ("Spine", "Abdomen", "LowerBack"),
        "chest": ("Chest", "Spine2", "Spine1", "Chest2", "Thorax", "UpperChest"),
        "neck": ("Neck",),
        "head": ("Head_End", "HeadEnd", "Head"),
        "shoulder": ("{Side}UpArm", "{Side}Shoulder", "{S}Shoulder", "{Side}Humerus"),
        "elbow": ("{Side}LowArm", "{Side}Elbow", "{S}Elbow", "{Side}ForeArm"),
        "wrist": ("{Side}Wrist", "{S}Wrist", "{Side}Hand"),
    },
    "daz": {  # DAZ/Poser-friendly CMU conversions: hip, abdomen, chest, lThigh, lShin, lShldr...
        "pelvis": ("hip", "pelvis"),
        "hip": ("{s}Thigh",),
        "knee": ("{s}Shin",),
        "ankle": ("{s}Foot",),
        "toe": ("{s}Toe", "{s}Foot_End"),
        "spine": ("abdomen",),
        "chest": ("chest",),
        "neck": ("neck",),
        "head": ("head_End", "head"),
        "shoulder": ("{s}Shldr",),
        "elbow": ("{s}ForeArm",),
        "wrist": ("{s}Hand",),
    },
}

MappingSource = str | Path | Mapping[str, str | Sequence[str]] | None
Array = npt.NDArray[np.float64]


def normalise(name: str) -> str:
    """Compare form of a joint name: no namespace prefix, separators or case."""
    return re.sub(r"[\s_\-.]", "", name.rsplit(":", 1)[-1]).lower()


def _expand(template: Mapping[str, tuple[str, ...]]) -> dict[str, tuple[str, ...]]:
    table: dict[str, tuple[str, ...]] = {}
    for key, candidates in template.items():
        if key not in _SIDED:
            table[key] = candidates
            continue
        for s, side, s_upper in (("l", "Left", "L"), ("r", "Right", "R")):
            table[f"{s}_{key}"] = tuple(c.format(s=s, Side=side, S=s_upper) for c in candidates)
    return table


TABLES: dict[str, dict[str, tuple[str, ...]]] = {
    name: _expand(template) for name, template in _TABLE_TEMPLATES.items()
}


def _find(candidates: Sequence[str], index: Mapping[str, str]) -> str | None:
    return next((index[normalise(c)] for c in candidates if normalise(c) in index), None)


def resolve(names: Sequence[str], mapping: MappingSource, source: Path) -> dict[str, str]:
    """Landmark -> joint name for a skeleton: the first built-in table that finds every
    required landmark, with `mapping` (TOML file or dict) overriding; or a MocapError."""
    index: dict[str, str] = {}
    for name in names:
        index.setdefault(normalise(name), name)
    user = read_mapping(mapping, index, source) if mapping is not None else {}
    best: dict[str, str] = {}
    for table in TABLES.values():
        found = {k: hit for k, c in table.items() if (hit := _find(c, index)) is not None}
        found.update(user)
        if all(k in found for k in REQUIRED):
            return {k: found[k] for k in LANDMARKS if k in found}
        if len(found) > len(best):
            best = found
    raise MocapError(_no_match(names, best, source))


def read_mapping(
    mapping: str | Path | Mapping[str, str | Sequence[str]],
    index: Mapping[str, str],
    source: Path,
) -> dict[str, str]:
    """A user's landmark mapping checked against the skeleton (normalised name -> name)."""
    where = "mapping"
    if isinstance(mapping, str | Path):
        where = str(mapping)
        try:
            data = tomllib.loads(read_text(mapping, MocapError, "the mapping"))
        except tomllib.TOMLDecodeError as exc:
            raise MocapError(f"{where}: invalid TOML: {exc}") from None
        table = data.get("landmarks")
        if not isinstance(table, dict):
            raise MocapError(f"{where}: expected a [landmarks] table (see `{_TEMPLATE_HINT}`)")
    else:
        table = dict(mapping)
    out: dict[str, str] = {}
    for key, value in table.items():
        if key not in LANDMARKS:
            raise MocapError(f"{where}: unknown landmark '{key}' (expected {', '.join(LANDMARKS)})")
        candidates = [value] if isinstance(value, str) else value
        if not isinstance(candidates, list | tuple) or not all(
            isinstance(c, str) for c in candidates
        ):
            raise MocapError(f"{where}: landmarks.{key} must be a joint name or a list of names")
        hit = _find(candidates, index)
        if hit is None:
            raise MocapError(
                f"{where}: landmarks.{key} = {value!r} is not a joint of {source} "
                f"(joints: {', '.join(index.values())})"
            )
        out[key] = hit
    return out


_TEMPLATE_HINT = "load_mocap(path, mapping='my_skeleton.toml')"


def mapping_template(guess: Mapping[str, str] | None = None) -> str:
    """A mapping TOML with every landmark key, filled from `guess` where known.

    The text `load_mocap(..., mapping=)` reads: a `[landmarks]` table, one line per landmark
    in LANDMARKS order, each with a comment saying which joint it is.

    Args:
        guess: landmark -> joint name of the landmarks known already; the others (all of
            them with None) get "".

    Returns:
        The TOML text (no trailing newline).
    """
    guess = guess or {}
    lines = ["[landmarks]"]
    for key in LANDMARKS:
        value = f'"{guess[key]}"' if key in guess else '""'
        about = DESCRIPTIONS.get(key)
        if about is None:
            about = ("left " if key[0] == "l" else "right ") + DESCRIPTIONS[key[2:]]
        lines.append(f"{key:<10} = {value:<18} # {about}")
    return "\n".join(lines)


def _no_match(names: Sequence[str], guess: Mapping[str, str], source: Path) -> str:
    missing = [k for k in REQUIRED if k not in guess]
    return (
        f"{source}: joint names match no built-in landmark table ({', '.join(TABLES)}); "
        f"not found: {', '.join(missing)}. Joints: {', '.join(names)}.\n"
        f"Write a mapping TOML naming the joint for each landmark and pass it as {_TEMPLATE_HINT}"
        " (keys found already and optional ones may be left out):\n" + mapping_template(guess)
    )


def skeleton(names: Sequence[str]) -> tuple[tuple[str, ...], tuple[int, ...]]:
    """The known landmarks among `names`, in LANDMARKS order, and each one's parent index: the
    nearest ancestor present in PARENTS' tree, -1 for none (a root)."""
    present = [name for name in LANDMARKS if name in names]
    index = {name: i for i, name in enumerate(present)}
    parents = []
    for name in present:
        parent = PARENTS[name]
        while parent is not None and parent not in index:
            parent = PARENTS[parent]
        parents.append(-1 if parent is None else index[parent])
    return tuple(present), tuple(parents)


def landmark_positions(
    positions: Array, names: Sequence[str], mapping: Mapping[str, str]
) -> dict[str, Array]:
    """Landmark trajectories (T, 3), new arrays, from joint positions (T, J, 3)."""
    index = {name: j for j, name in enumerate(names)}
    try:
        out = {k: positions[:, index[v]] for k, v in mapping.items()}
    except KeyError as exc:
        raise MocapError(f"landmark joint {exc} is not in the skeleton") from None
    missing = [k for k in REQUIRED if k not in out]
    if missing:
        raise MocapError(f"landmarks {missing} have no joint in the mapping")
    if "pelvis" not in out:
        out["pelvis"] = (out["l_hip"] + out["r_hip"]) / 2
    if "neck" not in out:
        out["neck"] = (out["l_shoulder"] + out["r_shoulder"]) / 2
    pelvis, neck = out["pelvis"], out["neck"]
    has_spine, has_chest = "spine" in out, "chest" in out
    if not has_chest:
        out["chest"] = (out["spine"] + neck) / 2 if has_spine else pelvis + (neck - pelvis) * 2 / 3
    if not has_spine:
        out["spine"] = (pelvis + out["chest"]) / 2 if has_chest else pelvis + (neck - pelvis) / 3
    return {k: np.array(out[k], dtype=float) for k in LANDMARKS}
