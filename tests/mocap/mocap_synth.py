"""Small mocap files for the tests: one synthetic body written as ASF/AMC and as BVH, and a
minimal BVH humanoid. Rotations here come from scipy (an independent check of the readers):
Acclaim rotations are extrinsic in listed order, BVH channels intrinsic in listed order."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation


@dataclass(frozen=True)
class SynthBone:
    asf: str
    bvh: str
    parent: str  # ASF name or "root"
    direction: tuple[float, float, float]  # Y-up
    length: float  # CMU units (1/0.45 inch)
    axis: tuple[float, float, float] = (0.0, 0.0, 0.0)  # degrees, order XYZ
    dofs: tuple[str, ...] = ()


def _limbs(s: str) -> tuple[list[SynthBone], list[SynthBone]]:
    """Leg and arm bones of side "l" or "r" (mirrored in x, axes mirrored about z)."""
    x, az = (1.0, 20.0) if s == "l" else (-1.0, -20.0)
    side = "Left" if s == "l" else "Right"
    leg = [
        SynthBone(f"{s}hipjoint", f"{s.upper()}HipJoint", "root", (x, -0.8, 0.3), 2.4),
        SynthBone(f"{s}femur", f"{side}UpLeg", f"{s}hipjoint", (x * 0.34, -0.94, 0.0), 7.3,
                  (0, 0, az), ("rx", "ry", "rz")),
        SynthBone(f"{s}tibia", f"{side}Leg", f"{s}femur", (x * 0.34, -0.94, 0.0), 7.8,
                  (0, 0, az), ("rx",)),
        SynthBone(f"{s}foot", f"{side}Foot", f"{s}tibia", (x * 0.09, -0.25, 0.97), 2.0,
                  (-90, 0, az), ("rx", "rz")),
        SynthBone(f"{s}toes", f"{side}ToeBase", f"{s}foot", (0.0, 0.0, 1.0), 1.0,
                  (-90, 0, az), ("rx",)),
    ]  # fmt: skip
    arm = [
        SynthBone(f"{s}clavicle", f"{side}Shoulder", "thorax", (x, 0.2, -0.05), 3.4,
                  (0, 0, -az), ("ry", "rz")),
        SynthBone(f"{s}humerus", f"{side}Arm", f"{s}clavicle", (x, 0.0, 0.0), 5.0,
                  (0, 0, x * 90), ("rz", "rx", "ry")),
        SynthBone(f"{s}radius", f"{side}ForeArm", f"{s}humerus", (x, 0.0, 0.0), 3.4,
                  (0, 0, x * 90), ("rx",)),
        SynthBone(f"{s}wrist", f"{side}Hand", f"{s}radius", (x, 0.0, 0.0), 1.7,
                  (0, 0, x * 90), ("ry",)),
    ]  # fmt: skip
    return leg, arm


def synth_body() -> list[SynthBone]:
    """A CMU-like body (CMU ASF and CMU BVH names), bones listed parents first."""
    (l_leg, l_arm), (r_leg, r_arm) = _limbs("l"), _limbs("r")
    xyz = ("rx", "ry", "rz")
    trunk = [
        SynthBone("lowerback", "LowerBack", "root", (0.0, 0.98, -0.2), 2.1, dofs=xyz),
        SynthBone("upperback", "Spine", "lowerback", (0.0, 1.0, 0.02), 2.1, dofs=xyz),
        SynthBone("thorax", "Spine1", "upperback", (0.0, 1.0, 0.1), 2.0, dofs=xyz),
        SynthBone("lowerneck", "Neck", "thorax", (0.0, 1.0, 0.1), 1.6, dofs=xyz),
        SynthBone("upperneck", "Neck1", "lowerneck", (0.0, 1.0, -0.1), 1.6, dofs=xyz),
        SynthBone("head", "Head", "upperneck", (0.0, 1.0, 0.0), 1.7, dofs=xyz),
    ]
    return l_leg + r_leg + trunk + l_arm + r_arm


# Frames of a take the robot can follow: the motion of synth_motion spread over half a second
# at 120 Hz, within the joints' velocity limits (in 6 frames the IK lags its feet 4 cm behind)
TRACKABLE = 60


def synth_files(folder: Path, frames: int = 6) -> dict[str, Path]:
    """One synthetic body and motion of `frames` frames as 07.asf + 07_03.amc and as 07_03.bvh
    in `folder`."""
    bones = synth_body()
    values = synth_motion(bones, frames)
    amc = folder / "07_03.amc"
    amc.write_text(amc_text(bones, values))
    bvh = folder / "07_03.bvh"
    bvh.write_text(bvh_text(bones, values))
    return {"asf": write_asf(folder / "07.asf", bones), "amc": amc, "bvh": bvh}


def synth_motion(bones: list[SynthBone], frames: int = 6) -> dict[str, np.ndarray]:
    """Dof values (frames, n) per bone plus "root" (TX TY TZ RX RY RZ), degrees: walking legs,
    a little of everything else."""
    t = np.linspace(0.0, 1.0, frames)[:, None]
    rng = np.random.default_rng(7)
    values = {
        "root": np.hstack([
            2.0 + 0.1 * t, 16.0 + 0.2 * np.sin(6 * t), 3.0 + 20.0 * t,
            5.0 * np.sin(3 * t), 10.0 + 30 * t, 2.0 * t,
        ])
    }  # fmt: skip
    for b in bones:
        if not b.dofs:
            continue
        v = rng.uniform(-15, 15, (1, len(b.dofs))) + 10 * np.sin(5 * t + rng.uniform(0, 6))
        if b.asf[1:] == "femur":
            v[:, 0] = (-30 if b.asf[0] == "l" else 20) * np.sin(4 * t[:, 0] + 0.3)
        if b.asf[1:] == "tibia":
            v[:, 0] = 10 + 50 * np.sin(4 * t[:, 0]) ** 2
        values[b.asf] = v
    return values


def write_asf(path: Path, bones: list[SynthBone], angle: str = "deg") -> Path:
    """An Acclaim ASF (CMU units: length 0.45)."""
    scale = 1.0 if angle == "deg" else np.pi / 180
    lines = [
        "# synthetic skeleton", ":version 1.10", ":name VICON", ":units", "  mass 1.0",
        "  length 0.45", f"  angle {angle}", ":documentation", "   made by the tests",
        ":root", "   order TX TY TZ RX RY RZ", "   axis XYZ", "   position 0 0 0",
        "   orientation 0 0 0", ":bonedata",
    ]  # fmt: skip
    for n, b in enumerate(bones, 1):
        ax = " ".join(f"{a * scale:.9g}" for a in b.axis)
        lines += ["  begin", f"     id {n}", f"     name {b.asf}"]
        lines += [f"     direction {' '.join(f'{d:.9g}' for d in _unit(b.direction))}"]
        lines += [f"     length {b.length}", f"     axis {ax}  XYZ"]
        if b.dofs:
            lines += [f"    dof {' '.join(b.dofs)}", "    limits (-180.0 180.0)"]
            lines += ["           (-180.0 180.0)"] * (len(b.dofs) - 1)
        lines += ["  end"]
    lines += [":hierarchy", "  begin"]
    parents = ["root"] + [b.asf for b in bones]
    for p in parents:
        kids = [b.asf for b in bones if b.parent == p]
        if kids:
            lines.append(f"    {p} {' '.join(kids)}")
    lines.append("  end")
    path.write_text("\n".join(lines) + "\n")
    return path


def amc_text(bones: list[SynthBone], values: dict[str, np.ndarray], crlf: bool = False) -> str:
    lines = ["# made by the tests", ":FULLY-SPECIFIED", ":DEGREES"]
    frames = values["root"].shape[0]
    order = ["root"] + [b.asf for b in bones if b.dofs]
    for f in range(frames):
        lines.append(str(f + 1))
        lines += [f"{name} {' '.join(f'{v:.9g}' for v in values[name][f])}" for name in order]
    return ("\r\n" if crlf else "\n").join(lines) + "\n"


def _unit(v: tuple[float, float, float]) -> np.ndarray:
    a = np.asarray(v, dtype=float)
    return a / np.linalg.norm(a)


def acclaim_local(bone: SynthBone, values: np.ndarray) -> Rotation:
    """C M C^-1 with C from the bone's axis (XYZ, extrinsic) and M from its dofs in order."""
    c = Rotation.from_euler("xyz", bone.axis, degrees=True)
    axes = "".join(d[1] for d in bone.dofs)
    return c * Rotation.from_euler(axes, values, degrees=True) * c.inv()


def bvh_text(
    bones: list[SynthBone], values: dict[str, np.ndarray], order: str = "ZXY", rate: float = 120.0
) -> str:
    """The same body and motion as BVH in CMU units: a joint per bone at its start, End Sites
    at leaf ends, rotation channels in `order`."""
    vec = {b.asf: _unit(b.direction) * b.length for b in bones} | {"root": np.zeros(3)}
    out = ["HIERARCHY", "ROOT Hips", "{", "  OFFSET 0 0 0"]
    out.append(f"  CHANNELS 6 Xposition Yposition Zposition {_channels(order)}")
    emitted: list[SynthBone] = []

    def joint(b: SynthBone, depth: int) -> None:
        pad = "  " * depth
        emitted.append(b)
        out.extend([f"{pad}JOINT {b.bvh}", f"{pad}{{", f"{pad}  OFFSET {_xyz(vec[b.parent])}"])
        out.append(f"{pad}  CHANNELS 3 {_channels(order)}")
        kids = [k for k in bones if k.parent == b.asf]
        for k in kids:
            joint(k, depth + 1)
        if not kids:
            out.extend([f"{pad}  End Site", f"{pad}  {{", f"{pad}    OFFSET {_xyz(vec[b.asf])}"])
            out.append(f"{pad}  }}")
        out.append(f"{pad}}}")

    for b in bones:
        if b.parent == "root":
            joint(b, 1)
    out.append("}")
    frames = values["root"].shape[0]
    columns = [values["root"][:, :3]]
    root_rot = Rotation.from_euler("xyz", values["root"][:, 3:], degrees=True)
    columns.append(root_rot.as_euler(order, degrees=True))
    for b in emitted:
        if b.dofs:
            local = acclaim_local(b, values[b.asf])
            columns.append(local.as_euler(order, degrees=True))
        else:
            columns.append(np.zeros((frames, 3)))
    data = np.hstack(columns)
    out += ["MOTION", f"Frames: {frames}", f"Frame Time: {1 / rate:.7f}"]
    out += [" ".join(f"{v:.9f}" for v in row) for row in data]
    return "\n".join(out) + "\n"


def _channels(order: str) -> str:
    return " ".join(f"{a}rotation" for a in order)


def _xyz(v: np.ndarray) -> str:
    return " ".join(f"{x:.9f}" for x in v)


# A minimal BVH humanoid in metres, Y-up, facing +z, T-pose rest (arms along +-x).
MINI_JOINTS: list[tuple[str, str, tuple[float, float, float]]] = [
    ("Hips", "", (0.0, 0.0, 0.0)),
    ("LeftUpLeg", "Hips", (0.1, -0.05, 0.0)),
    ("LeftLeg", "LeftUpLeg", (0.0, -0.42, 0.0)),
    ("LeftFoot", "LeftLeg", (0.0, -0.42, 0.0)),
    ("LeftToeBase", "LeftFoot", (0.0, -0.06, 0.12)),
    ("RightUpLeg", "Hips", (-0.1, -0.05, 0.0)),
    ("RightLeg", "RightUpLeg", (0.0, -0.42, 0.0)),
    ("RightFoot", "RightLeg", (0.0, -0.42, 0.0)),
    ("RightToeBase", "RightFoot", (0.0, -0.06, 0.12)),
    ("Spine", "Hips", (0.0, 0.15, 0.0)),
    ("Spine1", "Spine", (0.0, 0.2, 0.0)),
    ("Neck", "Spine1", (0.0, 0.15, 0.0)),
    ("Head", "Neck", (0.0, 0.1, 0.0)),
    ("LeftArm", "Spine1", (0.18, 0.1, 0.0)),
    ("LeftForeArm", "LeftArm", (0.3, 0.0, 0.0)),
    ("LeftHand", "LeftForeArm", (0.25, 0.0, 0.0)),
    ("RightArm", "Spine1", (-0.18, 0.1, 0.0)),
    ("RightForeArm", "RightArm", (-0.3, 0.0, 0.0)),
    ("RightHand", "RightForeArm", (-0.25, 0.0, 0.0)),
]
MINI_END_SITES = {"LeftToeBase": (0.0, 0.0, 0.05), "RightToeBase": (0.0, 0.0, 0.05),
                  "Head": (0.0, 0.2, 0.0), "LeftHand": (0.1, 0.0, 0.0),
                  "RightHand": (-0.1, 0.0, 0.0)}  # fmt: skip


def mini_bvh(
    motion: list[dict[str, tuple[float, ...]]],
    *,
    order: dict[str, str] | None = None,
    scale: float = 1.0,
    names: dict[str, str] | None = None,
    frame_time: str = "0.0083333",
) -> str:
    """The minimal humanoid with one frame per dict: joint -> rotation values in its channel
    order (default ZYX; `order` overrides per joint), "root" -> position (m). Offsets are
    divided by `scale` (file units); `names` renames joints."""
    order = order or {}
    names = names or {}
    children: dict[str, list[str]] = {}
    for name, parent, _ in MINI_JOINTS:
        children.setdefault(parent, []).append(name)
    offsets = {name: np.array(off) / scale for name, _, off in MINI_JOINTS}
    out = ["HIERARCHY"]
    sequence: list[str] = []

    def joint(name: str, depth: int) -> None:
        pad = "\t" * depth
        sequence.append(name)
        kind = "ROOT" if depth == 0 else "JOINT"
        rot = _channels(order.get(name, "ZYX"))
        channels = f"6 Xposition Yposition Zposition {rot}" if depth == 0 else f"3 {rot}"
        out.extend([f"{pad}{kind} {names.get(name, name)}", f"{pad}{{"])
        out.extend([f"{pad}\tOFFSET {_xyz(offsets[name])}", f"{pad}\tCHANNELS {channels}"])
        for kid in children.get(name, []):
            joint(kid, depth + 1)
        if name in MINI_END_SITES:
            end = np.array(MINI_END_SITES[name]) / scale
            out.extend([f"{pad}\tEnd Site", f"{pad}\t{{", f"{pad}\t\tOFFSET {_xyz(end)}"])
            out.append(f"{pad}\t}}")
        out.append(f"{pad}}}")

    joint("Hips", 0)
    out += ["MOTION", f"Frames: {len(motion)}", f"Frame Time: {frame_time}"]
    for frame in motion:
        row = list(np.array(frame.get("root", (0.0, 0.9, 0.0))) / scale)
        for name in sequence:
            row += list(frame.get(name, (0.0, 0.0, 0.0)))
        out.append(" ".join(f"{v:.6f}" for v in row))
    return "\n".join(out) + "\n"


def arms_down(frames: int, start: int = 0) -> list[dict[str, tuple[float, ...]]]:
    """Frames of the minimal humanoid with arms hanging and legs swinging a little."""
    out = []
    for f in range(start, start + frames):
        swing = 10.0 * np.sin(0.2 * f)
        out.append({
            "root": (0.0, 0.9, 0.01 * f),
            "LeftArm": (-80.0, 0.0, 0.0), "RightArm": (80.0, 0.0, 0.0),
            "LeftUpLeg": (0.0, 0.0, swing), "RightUpLeg": (0.0, 0.0, -swing),
        })  # fmt: skip
    return out


def amc_in_radians(
    amc: Path, asf: Path, out: Path, root_turn: float = 0.0, frames: int | None = None
) -> Path:
    """`amc` (degrees) written to `out` with its rotation values in radians while its header
    and `asf` still declare degrees: the mix-up of a tool that exported radians. `root_turn`
    [rad] is added to the root's RY (2 pi: the same heading, past pi); `frames`: only the
    first ones."""
    from motionkit.mocap.asf_amc import read_asf

    skeleton = read_asf(asf)
    dofs = {"root": skeleton.root_order} | {b.name: b.dofs for b in skeleton.bones.values()}
    lines, count = [], 0
    for line in amc.read_text().splitlines():
        words = line.split()
        if words and words[0].isdigit():
            count += 1
            if frames is not None and count > frames:
                break
        elif words and words[0] in dofs:
            values = [float(w) for w in words[1:]]
            for i, dof in enumerate(dofs[words[0]]):
                if dof.startswith("r"):
                    turn = root_turn if (words[0], dof) == ("root", "ry") else 0.0
                    values[i] = np.radians(values[i]) + turn
            line = " ".join([words[0], *(f"{v:.9g}" for v in values)])
        lines.append(line)
    out.write_text("\n".join(lines) + "\n")
    return out
