"""A dataset: MCAP clips from folders and files, with a label and a weight per clip."""

from __future__ import annotations

from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

from motionkit.core.errors import DatasetError
from motionkit.dataset.amp import AmpPairs, amp_pairs
from motionkit.dataset.clip import read, read_metadata
from motionkit.dataset.trajectory import Metadata, Trajectory
from motionkit.robot import Robot


@dataclass(frozen=True)
class ClipEntry:
    path: Path
    metadata: Metadata
    frames: int
    duration: float  # s
    rate: float  # Hz
    weight: float

    @property
    def name(self) -> str:
        return self.path.stem

    @property
    def label(self) -> str:
        return self.metadata.kind


def find_clips(paths: Sequence[Path | str]) -> list[Path]:
    """MCAP files named directly or found (recursively, sorted) in the named folders (anything
    that is not a regular file is refused when read)."""
    found: list[Path] = []
    for path in map(Path, paths):
        if path.is_dir():
            found += sorted(path.rglob("*.mcap"))
        elif path.exists():
            found.append(path)
        else:
            raise DatasetError(f"{path}: no such file or folder")
    if not found:
        raise DatasetError(f"no .mcap clips in {', '.join(map(str, paths))}")
    return found


class MotionDataset:
    """Clips read lazily; `weights` maps a clip name (file stem) or a label to a weight (the
    clip name wins; unnamed clips weigh 1); `labels` keeps only clips of those kinds."""

    def __init__(
        self,
        paths: Sequence[Path | str],
        weights: Mapping[str, float] | None = None,
        labels: Sequence[str] | None = None,
    ) -> None:
        weights = dict(weights or {})
        entries = []
        for path in find_clips(paths):
            metadata, record = read_metadata(path)
            if labels is not None and metadata.kind not in labels:
                continue
            weight = weights.get(path.stem, weights.get(metadata.kind, 1.0))
            if weight < 0:
                raise DatasetError(f"{path}: negative weight {weight}")
            entries.append(
                ClipEntry(
                    path,
                    metadata,
                    int(record["frames"]),
                    float(record["duration"]),
                    float(record["rate"]),
                    float(weight),
                )
            )
        if not entries:
            raise DatasetError(
                f"no clips labelled {', '.join(labels or [])} in {list(map(str, paths))}"
            )
        self.clips = tuple(entries)

    def __len__(self) -> int:
        return len(self.clips)

    @property
    def duration(self) -> float:
        return sum(clip.duration for clip in self.clips)

    def trajectories(self) -> Iterator[tuple[ClipEntry, Trajectory]]:
        for clip in self.clips:
            yield clip, read(clip.path)

    def amp_pairs(self, robot: Robot, rate: float, *, heading_free: bool = True) -> AmpPairs:
        """AMP transition pairs of every clip at the control rate `rate` [Hz]."""
        for clip in self.clips:
            if clip.metadata.robot_hash != robot.model_hash:
                raise DatasetError(
                    f"{clip.path}: made for model {clip.metadata.robot_hash} of "
                    f"{clip.metadata.robot}, not {robot.model_hash} of {robot.name}"
                )
        return amp_pairs(
            [trajectory for _, trajectory in self.trajectories()],
            robot,
            rate,
            [clip.weight for clip in self.clips],
            heading_free=heading_free,
        )
