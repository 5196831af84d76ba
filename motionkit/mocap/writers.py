"""Write a MocapClip back to BVH (Y-up, any rotation order, chosen units), e.g. for Blender."""

from __future__ import annotations

import io
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from motionkit.core.errors import MocapError
from motionkit.files.outputs import atomic_output
from motionkit.mocap.skeleton import UNITS, Y_UP_TO_Z_UP, MocapClip


def write_bvh(path: str | Path, clip: MocapClip, *, order: str = "ZYX", units: str = "cm") -> Path:
    """Write `clip` as BVH: Y-up, lengths in `units`, root with 6 channels, other joints with
    rotation channels in `order` (BVH matrix order: "ZYX" is Rz Ry Rx); leaves become End Sites
    (their rotations move nothing). Clips with per-frame joint translations are not supported."""
    path = Path(path)
    order = order.upper()
    if sorted(order) != ["X", "Y", "Z"]:
        raise MocapError(f"{path}: rotation order '{order}' is not a permutation of XYZ")
    if units not in UNITS:
        raise MocapError(f"{path}: unknown units '{units}' (expected {', '.join(UNITS)})")
    if clip.translations is not None:
        raise MocapError(f"{path}: cannot write per-frame joint translations to BVH")
    skeleton, scale = clip.skeleton, UNITS[units]
    a = Y_UP_TO_Z_UP
    offsets = skeleton.offsets @ a / scale  # Z-up -> Y-up: v_y = A^T v_z, rows: v @ A
    children: dict[int, list[int]] = {j: [] for j in range(len(skeleton))}
    for j, p in enumerate(skeleton.parents[1:], start=1):
        children[p].append(j)
    moving = [j for j in range(len(skeleton)) if children[j]]

    out = io.StringIO()
    out.write("HIERARCHY\n")

    def joint(j: int, depth: int) -> None:
        pad = "  " * depth
        kind = "ROOT" if j == 0 else "JOINT"
        x, y, z = offsets[j]
        channels = " ".join(f"{c}rotation" for c in order)
        if j == 0:
            channels = f"6 Xposition Yposition Zposition {channels}"
        else:
            channels = f"3 {channels}"
        out.write(f"{pad}{kind} {skeleton.names[j]}\n{pad}{{\n")
        out.write(f"{pad}  OFFSET {x:.6f} {y:.6f} {z:.6f}\n{pad}  CHANNELS {channels}\n")
        for c in children[j]:
            if children[c]:
                joint(c, depth + 1)
            else:
                ex, ey, ez = offsets[c]
                out.write(
                    f"{pad}  End Site\n{pad}  {{\n{pad}    OFFSET {ex:.6f} {ey:.6f} {ez:.6f}\n"
                )
                out.write(f"{pad}  }}\n")
        out.write(f"{pad}}}\n")

    joint(0, 0)
    frames = clip.frames
    local = a.T @ clip.rotations[:, moving] @ a  # back to Y-up
    angles = Rotation.from_matrix(local.reshape(-1, 3, 3)).as_euler(order, degrees=True)
    root = clip.root_translation @ a / scale
    data = np.concatenate([root, angles.reshape(frames, -1)], axis=1)
    out.write(f"MOTION\nFrames: {frames}\nFrame Time: {1.0 / clip.rate:.8f}\n")
    np.savetxt(out, data, fmt="%.6f")
    with atomic_output(path) as stream:
        stream.write(out.getvalue().encode())
    return path
