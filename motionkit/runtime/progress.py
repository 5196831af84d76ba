"""Progress of long work. Library code reports it to a `Progress` callback (`silent` by default)
and never prints; the commands pass one that prints. `LineProgress` draws one task's progress on
stderr, fit for a terminal and for a log file alike."""

from __future__ import annotations

import sys
import time
from collections.abc import Callable
from typing import TextIO

Progress = Callable[[str], None]  # receives each line of a stage's progress


def silent(line: str) -> None:
    """The library's progress by default: nothing shown."""


class LineProgress:
    """One task's progress. On a terminal: one line rewritten in place (at most 10 updates a
    second). Elsewhere (a log file, a pipe): a plain line at most every `every` seconds, so
    that a log gets a few readable lines instead of one long line of carriage returns."""

    def __init__(self, name: str, stream: TextIO | None = None, every: float = 10.0) -> None:
        self.name, self.stream = name, stream or sys.stderr
        self.terminal = bool(getattr(self.stream, "isatty", lambda: False)())
        self.every = 0.1 if self.terminal else every
        self.shown, self.text, self.drawn = time.monotonic(), "", False

    def show(self, text: str) -> None:
        self.text = text
        now = time.monotonic()
        if now - self.shown >= self.every:
            self.shown = now
            self._write()

    def _write(self) -> None:
        line = f"{self.name}: {self.text}"
        self.stream.write(f"\r{line}" if self.terminal else f"{line}\n")
        self.stream.flush()
        self.drawn = True

    def close(self, keep: bool = True) -> None:
        """The last state as a line of its own (`keep`), or, on a terminal, the line erased."""
        if keep and self.text:
            self._write()
            if self.terminal:
                self.stream.write("\n")
        elif self.terminal and self.drawn:
            self.stream.write("\r\033[K")
        self.stream.flush()
