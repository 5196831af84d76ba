"""The timeline: which frame to show at which clip time, and how time advances (no server)."""

from __future__ import annotations

import numpy as np


class Playback:
    """Clip time over a frame time axis: play/pause, speed, loop.

    `time` is the clip's frame times [s] (strictly increasing). The frame shown at clip time t is
    the last frame whose time is <= t (the first frame before the clip starts).
    """

    def __init__(self, time: np.ndarray, speed: float = 1.0, loop: bool = True) -> None:
        self.time = np.asarray(time, dtype=float)
        if self.time.ndim != 1 or len(self.time) == 0:
            raise ValueError("a playback needs a 1-D array of at least one frame time")
        self.start, self.end = float(self.time[0]), float(self.time[-1])
        self.speed = speed
        self.loop = loop
        self.playing = False
        self.now = self.start

    @property
    def duration(self) -> float:
        return self.end - self.start

    def frame_at(self, t: float) -> int:
        """Index of the frame shown at clip time t."""
        index = int(np.searchsorted(self.time, t, side="right")) - 1
        return min(max(index, 0), len(self.time) - 1)

    @property
    def frame(self) -> int:
        return self.frame_at(self.now)

    def seek(self, t: float) -> int:
        """Jump to clip time t (clamped to the clip); returns the frame shown."""
        self.now = min(max(float(t), self.start), self.end)
        return self.frame

    def advance(self, wall_seconds: float) -> int:
        """Move on by `wall_seconds` of real time times the speed, when playing. At the end the
        clip starts again (loop) or stops on its last frame. Returns the frame shown."""
        if not self.playing or wall_seconds <= 0:
            return self.frame
        t = self.now + self.speed * wall_seconds
        if t > self.end:
            if self.loop and self.duration > 0:
                t = self.start + (t - self.start) % self.duration
            else:
                t, self.playing = self.end, False
        elif t < self.start:  # negative speed plays backwards
            if self.loop and self.duration > 0:
                t = self.end - (self.start - t) % self.duration
            else:
                t, self.playing = self.start, False
        self.now = t
        return self.frame
