"""Export clips for other tools: `.npz` arrays, or the `.npy` dict layout of amp-rsl-rl.

amp-rsl-rl (ami-iit) loads `<name>.npy` files holding a pickled dict with `joints_list`,
`joint_positions` (one row per frame), `root_position`, `root_quaternion` in (x, y, z, w) order
and `fps`, sampled uniformly; it differentiates positions for velocities itself.
"""

from __future__ import annotations

import io
import json
from dataclasses import asdict
from pathlib import Path

import numpy as np

from motionkit.dataset.amp import resample
from motionkit.dataset.trajectory import Trajectory
from motionkit.files.outputs import atomic_output

FORMATS = ("npz", "amp-rsl-rl")


def to_npz_bytes(trajectory: Trajectory) -> bytes:
    arrays = dict(trajectory.arrays())
    arrays |= {
        "joint_names": np.array(trajectory.joint_names),
        "jet_names": np.array(trajectory.jet_names),
        "foot_names": np.array(trajectory.foot_names),
        "corner_names": np.array(trajectory.corner_names, dtype=str),
        "landmark_names": np.array(trajectory.landmark_names, dtype=str),
        "landmark_parents": np.array(trajectory.landmark_parents, dtype=int),
        "metadata": np.array(json.dumps(asdict(trajectory.metadata), sort_keys=True)),
    }
    buffer = io.BytesIO()
    np.savez_compressed(buffer, **arrays)
    return buffer.getvalue()


def to_amp_rsl_rl(trajectory: Trajectory) -> dict[str, object]:
    """The amp-rsl-rl dict; a clip with uneven time steps is resampled at its median rate."""
    rate = trajectory.rate
    steps = np.diff(trajectory.time)
    if not np.allclose(steps, 1.0 / rate, rtol=1e-4, atol=1e-7):
        trajectory = resample(trajectory, rate)
    return {
        "joints_list": list(trajectory.joint_names),
        "joint_positions": trajectory.joint_positions.astype(np.float64),
        "root_position": trajectory.base_position.astype(np.float64),
        "root_quaternion": trajectory.base_orientation[:, [1, 2, 3, 0]].astype(np.float64),
        "fps": float(rate),
    }


def export(trajectory: Trajectory, name: str, out: Path, fmt: str) -> Path:
    """Write one clip in format `fmt` as out/<name>.npz or out/<name>.npy (atomically)."""
    if fmt == "npz":
        path, data = out / f"{name}.npz", to_npz_bytes(trajectory)
    else:
        buffer = io.BytesIO()
        np.save(buffer, np.array(to_amp_rsl_rl(trajectory), dtype=object), allow_pickle=True)
        path, data = out / f"{name}.npy", buffer.getvalue()
    with atomic_output(path) as stream:
        stream.write(data)
    return path
