"""What `motionkit view PATH` shows: a clip, a folder of clips or a training run, checked up front.

Every clip's index and metadata are read (and checked) before the server starts; the motion of a
clip is read only when it is shown, and a whole read checks the file's CRCs.

Optional extras a clip may carry, drawn when present:
- waypoints: metadata key "waypoints" (the config or metrics dict), a list of [x, y, z] [m];
- contact forces (trajopt clips): `Trajectory.contact_forces`, (frames, corners, 3) [N] in the
  world frame, one row per name of `corner_names` (the robot's sole corners);
- landmarks (retargeted clips): `Trajectory.landmarks`, (frames, L, 3) [m] in the world frame,
  with `landmark_parents`: the scaled human skeleton.
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from motionkit.dataset import Metadata, Trajectory, corner_names, read, read_metadata
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
    try:
        corners = json.loads(clip.record.get("corner_names", "[]"))  # absent in older clips
    except json.JSONDecodeError as exc:
        raise ViewerError(f"{clip.path}: metadata 'corner_names' is not valid JSON") from exc
    unknown = sorted(set(corners) - set(corner_names(robot)))
    if unknown:
        raise ViewerError(
            f"{clip.path}: the clip's contact forces act at corners {unknown} that robot "
            f"'{robot.name}' lacks (its sole corners: {list(corner_names(robot))})"
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


def contact_forces(trajectory: Trajectory, corners: Sequence[str]) -> np.ndarray | None:
    """The clip's planned contact forces (frames, len(corners), 3) [N] in the order of `corners`
    (zero at corners the clip has no force for), or None when it has none."""
    if trajectory.contact_forces is None:
        return None
    unknown = sorted(set(trajectory.corner_names) - set(corners))
    if unknown:
        raise ViewerError(f"contact forces at corners {unknown}, not sole corners {list(corners)}")
    rows = {name: i for i, name in enumerate(corners)}
    forces = np.zeros((trajectory.frames, len(corners), 3))
    forces[:, [rows[name] for name in trajectory.corner_names]] = trajectory.contact_forces
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
