"""What `motionkit view PATH` shows: a clip, a folder of clips or a training run, checked up front.

Every clip's index and metadata are read (and checked) before the server starts; the motion of a
clip is read only when it is shown, and must then pass the checks of `dataset validate` (a clip
made for another model of the robot, with the same names, is shown with a warning). Every text a
clip carries reaches the page escaped (`literal`): the page renders Markdown and raw HTML.

Optional extras a clip may carry, drawn when present:
- waypoints: metadata key "waypoints" (the config or metrics dict), a list of [x, y, z] [m], or
  of [time, x, y, z] (a rollout's: the clip time [s] each became the target);
- contact forces (trajopt clips): `Trajectory.contact_forces`, (frames, corners, 3) [N] in the
  world frame, one row per name of `corner_names` (the robot's sole corners);
- landmarks (retargeted clips): `Trajectory.landmarks`, (frames, L, 3) [m] in the world frame,
  with `landmark_parents`: the scaled human skeleton.
"""

from __future__ import annotations

import html
import json
import re
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from motionkit.core.errors import DatasetError, ViewerError
from motionkit.dataset import Metadata, Trajectory, corner_names, read_metadata
from motionkit.dataset.validate import read_valid
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
        return self.names("joint")

    def names(self, kind: str) -> tuple[str, ...]:
        """The clip's joint, jet or foot names (`kind`), from its checked metadata."""
        return tuple(json.loads(self.record[f"{kind}_names"]))


def resolve_clips(path: Path | str) -> list[ClipInfo]:
    """A clip, or every *.mcap under a folder (newest first), each with its metadata checked.

    Only the metadata is read, not the motion. Hidden files (a leading ".") in a folder are
    left out.

    Args:
        path: a .mcap clip, or a folder searched recursively for them.

    Returns:
        One ClipInfo (path, metadata, raw record, modification time) per clip, the most
        recently modified first.

    Raises:
        ViewerError: a missing path, a folder without clips, or the first clip whose metadata
            cannot be read.
    """
    path = Path(path)
    if path.is_dir():
        files = [p for p in path.rglob("*.mcap") if p.is_file() and not p.name.startswith(".")]
        if not files:
            raise ViewerError(f"{path}: no .mcap clips in this folder (searched recursively)")
    elif path.exists():
        files = [path]  # anything but a regular file is refused when read
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
    expected = {
        "joint": robot.joint_names,
        "jet": tuple(jet.name for jet in robot.spec.jets),
        "foot": tuple(foot.side for foot in robot.spec.feet),
    }
    for kind, names in expected.items():
        if clip.names(kind) != names:
            raise ViewerError(
                f"{clip.path}: the clip's {kind}s {list(clip.names(kind))} are not those of robot "
                f"'{robot.name}' {list(names)}; pass its robot with --urdf/--spec"
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


def load_motion(clip: ClipInfo, robot: Robot) -> Trajectory:
    """The clip's motion, checked as `dataset validate` checks it against `robot` (another model
    of the robot allowed), or a ViewerError naming the file and the failed check."""
    try:
        return read_valid(clip.path, robot, other_model=True)
    except DatasetError as exc:
        raise ViewerError(str(exc)) from exc


def waypoints(clip: ClipInfo) -> np.ndarray:
    """(N, 3) waypoints [m] from the metadata (record, config or metrics key "waypoints": rows
    of [x, y, z], or a rollout's [time, x, y, z]); (0, 3) when there are none."""
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
        points = np.asarray(value, dtype=float)
        if points.ndim == 2 and points.shape[1] == 4:  # a rollout's [time, x, y, z] rows
            points = points[:, 1:]
        points = points.reshape(-1, 3)
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
    """Markdown: what the page shows (clip, source, labels, metrics); every text from the clip
    (or naming it) goes in `literal`."""
    meta = clip.metadata
    source = meta.source
    lines = [
        f"**{literal(clip.name)}** — {literal(meta.kind)}, made by {literal(meta.generator)}",
        "",
        f"{clip.frames} frames, {clip.duration:.2f} s at {clip.rate:.1f} Hz; "
        f"robot {literal(meta.robot)}",
        "",
        f"file {literal(str(clip.path))}",
    ]
    if source.clip or source.file:
        file = f" ({source.file})" if source.file else ""
        lines += ["", f"source: {literal(source.clip + file)}"]
    if source.licence:
        lines += ["", f"licence: {literal(source.licence)}"]
    if warning:
        lines += ["", f"⚠ {literal(warning)}"]
    scalars = {k: v for k, v in meta.metrics.items() if isinstance(v, int | float | str)}
    if scalars:
        lines += ["", "| metric | value |", "|---|---|"]
        lines += [f"| {literal(k)} | {literal(_short(v))} |" for k, v in sorted(scalars.items())]
    return "\n".join(lines)


# Markdown's inline punctuation: emphasis, code, links and images, table cells, strikethrough
_MARKDOWN = re.compile(r"([\\`*_\[\]()!|~])")


def literal(text: str) -> str:
    """`text` for a Markdown page that renders raw HTML, shown as typed, within a line: on one
    line, Markdown punctuation backslash-escaped (no emphasis, code, link, image or table cell),
    then HTML-escaped (no tag, entity or attribute)."""
    flat = " ".join(text.split())
    return html.escape(_MARKDOWN.sub(r"\\\1", flat), quote=True)


def _short(value: float | int | str) -> str:
    if isinstance(value, float):
        return f"{value:.4g}"
    return str(value)
