"""A motion clip drawn into a GIF or an MP4 without a browser (`motionkit render`).

    from motionkit.viewer.render import RenderConfig, render_clip
    rendered = render_clip("plays/play.mcap", "play.gif", robot, RenderConfig(fps=30))

One picture every 1/fps s of clip time, each showing the clip's last frame at or before it:
the robot with its meshes on a checker floor, the camera following its base, flames on the
firing jets, the clip's waypoints and its terrain, if it records one (`offscreen.ClipRenderer`,
MuJoCo's offscreen renderer);
the file is written whole or not at all (`animation`). Importing this module imports neither
mujoco nor Pillow.
"""

from __future__ import annotations

import math
import time
from collections.abc import Iterable, Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from motionkit.core.checks import check, refusal
from motionkit.core.errors import ViewerError
from motionkit.dataset import Trajectory
from motionkit.robot import Robot
from motionkit.robot.geometry import Array
from motionkit.runtime.progress import Progress, silent
from motionkit.viewer.animation import animation_writer
from motionkit.viewer.meshes import robot_meshes
from motionkit.viewer.offscreen import ClipRenderer
from motionkit.viewer.sources import ClipInfo, check_robot, load_motion, resolve_clips, waypoints
from motionkit.viewer.terrain import clip_terrain

MAX_FPS = 100.0  # pictures per second
MAX_SIZE = 4096  # pixels, of the width and of the height


@dataclass(frozen=True)
class RenderConfig:
    """How a clip is drawn: picture rate and size, the part of the clip, the camera."""

    fps: float = 30.0  # pictures per second of clip time (the clip's frames are subsampled)
    width: int = 480  # pixels
    height: int = 360  # pixels
    start: float = 0.0  # s after the clip's first frame
    seconds: float | None = None  # s of clip from `start`; None: to the end
    distance: float = 3.5  # m from the base to the camera
    azimuth: float = 60.0  # deg about the vertical from the robot's mean front (90: its left)
    elevation: float = -15.0  # deg, of the camera's view above the horizon (negative: down)
    shadows: bool = True

    def __post_init__(self) -> None:
        check(self, ViewerError, "> 0", "fps", "distance")
        check(self, ViewerError, ">= 0", "start")
        check(self, ViewerError, "finite", "azimuth", "elevation")
        if self.seconds is not None:
            check(self, ViewerError, "> 0", "seconds")
        if self.fps > MAX_FPS:
            raise refusal(ViewerError, "fps", f"at most {MAX_FPS:g}", self.fps)
        for name in ("width", "height"):
            value = getattr(self, name)
            if not (isinstance(value, int) and 16 <= value <= MAX_SIZE):
                expected = f"a whole number of pixels from 16 to {MAX_SIZE}"
                raise refusal(ViewerError, name, expected, value)
        if not -90 < self.elevation < 90:
            raise refusal(ViewerError, "elevation", "in (-90, 90) degrees", self.elevation)


@dataclass(frozen=True)
class Rendered:
    """What `render_clip` wrote, and what drawing it took."""

    path: Path
    frames: int  # pictures written
    start: float  # s after the clip's first frame, of the first picture
    seconds: float  # s of clip time from the first picture to the last
    render_seconds: float  # wall time spent drawing (encoding not counted)
    warnings: tuple[str, ...]  # a clip made for another model of the robot; meshes not found

    @property
    def seconds_per_frame(self) -> float:
        return self.render_seconds / self.frames


def render_clip(
    clip: Path | str,
    out: Path | str,
    robot: Robot,
    config: RenderConfig | None = None,
    progress: Progress = silent,
) -> Rendered:
    """Draw a motion clip into an animated GIF or an MP4, written whole or not at all.

    Args:
        clip: an MCAP clip written by motionkit, checked as `motionkit dataset validate` checks
            it (a clip made for another model of the robot passes with a warning).
        out: the .gif or .mp4 file to write; replaced only once the whole animation is written.
        robot: the robot the clip was made for.
        config: picture rate and size, the part of the clip and the camera (RenderConfig()).
        progress: receives a line about every tenth of the pictures.

    Returns:
        The file, its picture count, the clip time it covers, the time drawing took and the
        warnings.

    Raises:
        ViewerError: a bad output name or place, no encoder for it, a missing, corrupt or
            invalid clip, a clip for another robot, a start past the clip's end, or no OpenGL.
    """
    config = config or RenderConfig()
    out = Path(out)
    write = animation_writer(out, config.fps, (config.width, config.height))
    info, motion, warning = load_clip(Path(clip), robot)
    shown = frame_indices(motion.time, config)
    meshes, problems = robot_meshes(robot)
    notes = tuple(n for n in (warning, *(f"mesh not drawn: {p}" for p in problems)) if n)
    spent = [0.0]
    with ClipRenderer(robot, config, meshes, waypoints(info), clip_terrain(info)) as renderer:
        renderer.aim(motion.base_orientation[shown], robot.spec.forward)
        pictures = (renderer.draw(motion, int(i), info.name) for i in shown)
        write(_timed(pictures, len(shown), spent, progress), len(shown))
    first, last = motion.time[shown[0]], motion.time[shown[-1]]
    return Rendered(
        out,
        len(shown),
        start=float(first - motion.time[0]),
        seconds=float(last - first),
        render_seconds=spent[0],
        warnings=notes,
    )


def load_clip(path: Path, robot: Robot) -> tuple[ClipInfo, Trajectory, str]:
    """The clip's ClipInfo, its checked motion and a warning ("" unless it was made for another
    model of the robot); a ViewerError for a folder or a missing, corrupt or invalid file."""
    if path.is_dir():
        raise ViewerError(f"{path}: is a folder; give one .mcap clip")
    [info] = resolve_clips(path)
    warning = check_robot(info, robot)
    return info, load_motion(info, robot), warning


def frame_indices(time: Array, config: RenderConfig) -> np.ndarray:
    """The clip frame of each picture: a picture every 1/fps s of clip time from `start` after
    the first frame, for `seconds` or to the end, showing the last frame at or before it."""
    begin = float(time[0]) + config.start
    if begin > time[-1]:
        raise ViewerError(
            f"--start {config.start:g} s is past the end of the clip "
            f"({float(time[-1] - time[0]):.3f} s long)"
        )
    end = float(time[-1])
    if config.seconds is not None:
        end = min(end, begin + config.seconds)
    count = math.floor((end - begin) * config.fps + 1e-6) + 1
    at = begin + np.arange(count) / config.fps + 1e-9  # a frame exactly on time counts
    return np.clip(np.searchsorted(time, at, side="right") - 1, 0, len(time) - 1)


def _timed(
    pictures: Iterable[np.ndarray], count: int, spent: list[float], progress: Progress
) -> Iterator[np.ndarray]:
    """`pictures`, adding the time each took to draw to spent[0]; a progress line every tenth."""
    every = max(1, count // 10)
    clock = time.perf_counter()
    for done, picture in enumerate(pictures, start=1):
        spent[0] += time.perf_counter() - clock
        if done % every == 0 or done == count:
            progress(f"drew {done}/{count} frames ({1000 * spent[0] / done:.0f} ms each)")
        yield picture
        clock = time.perf_counter()
