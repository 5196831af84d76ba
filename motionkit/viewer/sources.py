"""What `motionkit view PATH` shows: a clip, a folder of clips or a training run, checked up front.

Every clip's index and metadata are read (and checked) before the server starts; the motion of a
clip is read only when it is shown, and a whole read checks the file's CRCs.

Optional extras a clip may carry, drawn when present:
- waypoints: metadata key "waypoints" (the config or metrics dict), a list of [x, y, z] [m];
- contact forces: a `contact_forces` array on the Trajectory, (frames, corners, 3) [N] in the
  world frame, corners in spec order (every foot's sole corners, feet in spec order).
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from motionkit.dataset import Metadata, Trajectory, read, read_metadata
from motionkit.errors import DatasetError, ViewerError
from motionkit.robot import Robot


@dataclass(frozen=True)
class ClipInfo:
    """One clip as listed before its motion is read."""

    path: Path
    metadata: Metadata
    record: dict[str, str]  # the raw metadata record (frames, rate, names...)
    modified: float  # file modification time [s since the epoch]

    @property
    def name(self) -> str:
        return self.path.stem

    @property
    def frames(self) -> int:
        return int(self.record["frames"])

    @property
    def duration(self) -> float:
        return float(self.record["duration"])

    @property
    def rate(self) -> float:
        return float(self.record["rate"])

    @property
    def joint_names(self) -> tuple[str, ...]:
        return tuple(json.loads(self.record["joint_names"]))


def resolve_clips(path: Path | str) -> list[ClipInfo]:
    """A clip, or every *.mcap under a folder (newest first), each with its metadata checked;
    a ViewerError names the first missing or unreadable file."""
    path = Path(path)
    if path.is_dir():
        files = [p for p in path.rglob("*.mcap") if p.is_file() and not p.name.startswith(".")]
        if not files:
            raise ViewerError(f"{path}: no .mcap clips in this folder (searched recursively)")
    elif path.is_file():
        files = [path]
    else:
        raise ViewerError(f"{path}: no such file or folder")
    clips = []
    for file in files:
        try:
            metadata, record = read_metadata(file)
        except DatasetError as exc:
            raise ViewerError(str(exc)) from exc
        clips.append(ClipInfo(file, metadata, record, file.stat().st_mtime))
    clips.sort(key=lambda c: (-c.modified, str(c.path)))
    return clips


def check_robot(clip: ClipInfo, robot: Robot) -> str:
    """ "" when the clip fits the robot; a warning when only the model hash differs (the same
    joints, e.g. another icub-models release); a ViewerError when the joints differ."""
    if clip.joint_names != robot.joint_names:
        raise ViewerError(
            f"{clip.path}: the clip's joints {list(clip.joint_names)} are not those of robot "
            f"'{robot.name}' {list(robot.joint_names)}; pass its robot with --urdf/--spec"
        )
    if (clip.metadata.robot, clip.metadata.robot_hash) != (robot.name, robot.model_hash):
        return (
            f"{clip.path.name} was made for {clip.metadata.robot} model "
            f"{clip.metadata.robot_hash}; shown on {robot.name} model {robot.model_hash}"
        )
    return ""


def load_motion(clip: ClipInfo) -> Trajectory:
    """The clip's motion (CRCs checked), or a ViewerError naming the file."""
    try:
        return read(clip.path)
    except DatasetError as exc:
        raise ViewerError(str(exc)) from exc


def waypoints(clip: ClipInfo) -> np.ndarray:
    """(N, 3) waypoints [m] from the metadata (record, config or metrics key "waypoints");
    (0, 3) when there are none."""
    meta = clip.metadata
    value: Any = None
    if "waypoints" in clip.record:
        try:
            value = json.loads(clip.record["waypoints"])
        except json.JSONDecodeError as exc:
            raise ViewerError(f"{clip.path}: metadata 'waypoints' is not valid JSON") from exc
    else:
        value = meta.config.get("waypoints", meta.metrics.get("waypoints"))
    if value is None:
        return np.zeros((0, 3))
    try:
        points = np.asarray(value, dtype=float).reshape(-1, 3)
    except (TypeError, ValueError) as exc:
        raise ViewerError(
            f"{clip.path}: metadata 'waypoints' should be a list of [x, y, z], got {value!r:.80}"
        ) from exc
    if not np.all(np.isfinite(points)):
        raise ViewerError(f"{clip.path}: metadata 'waypoints' holds non-finite values")
    return points


def contact_forces(trajectory: Trajectory, corners: int) -> np.ndarray | None:
    """The clip's planned contact forces (frames, corners, 3) [N], or None when it has none."""
    forces = getattr(trajectory, "contact_forces", None)
    if forces is None:
        return None
    forces = np.asarray(forces, dtype=float)
    if forces.shape != (trajectory.frames, corners, 3):
        forces = forces.reshape(trajectory.frames, -1, 3) if forces.size else forces
        if forces.shape != (trajectory.frames, corners, 3):
            raise ViewerError(
                f"contact_forces has shape {np.shape(forces)}, expected "
                f"({trajectory.frames}, {corners}, 3): one force per sole corner"
            )
    return forces


def describe(clip: ClipInfo, warning: str = "") -> str:
    """Markdown: what the page shows (clip, source, labels, metrics)."""
    meta = clip.metadata
    source = meta.source
    lines = [
        f"**{clip.name}** — {meta.kind}, made by {meta.generator}",
        "",
        f"{clip.frames} frames, {clip.duration:.2f} s at {clip.rate:.1f} Hz; robot {meta.robot}",
        "",
        f"`{clip.path}`",
    ]
    if source.clip or source.file:
        lines += ["", f"source: {source.clip or ''} {f'({source.file})' if source.file else ''}"]
    if source.licence:
        lines += ["", f"licence: {source.licence}"]
    if warning:
        lines += ["", f"⚠ {warning}"]
    scalars = {k: v for k, v in meta.metrics.items() if isinstance(v, int | float | str)}
    if scalars:
        lines += ["", "| metric | value |", "|---|---|"]
        lines += [f"| {k} | {_short(v)} |" for k, v in sorted(scalars.items())]
    return "\n".join(lines)


def _short(value: float | int | str) -> str:
    if isinstance(value, float):
        return f"{value:.4g}"
    return str(value)
