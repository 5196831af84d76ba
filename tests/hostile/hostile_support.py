"""Helpers of the hostile-input tests: run the CLI in this process and check that it refused
with one clear line and no traceback, snapshot an output folder, guard against a read that
blocks (a FIFO), write a clip with tampered metadata, find a free port."""

from __future__ import annotations

import re
import signal
import socket
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import pytest

import motionkit.dataset.clip as clip_module
from motionkit.cli import main
from motionkit.dataset import Trajectory, write
from motionkit.robot import Robot


def refused(
    argv: list[str], capsys: pytest.CaptureFixture, code: int, *patterns: str, report: bool = False
) -> str:
    """Run `motionkit argv`; it must exit `code` with one line on stderr that matches every
    pattern, and return it. With `report` (dataset validate): nothing on stderr, and the
    report's "PATH: FAILED" heading and its first [FAIL] line, which must match, returned as one
    line."""
    rc = main(argv)
    out, err = capsys.readouterr()
    assert "Traceback" not in out + err
    assert rc == code, (rc, out, err)
    if report:
        assert not err.strip(), err
        headings = [line for line in out.splitlines() if line.endswith(": FAILED")]
        fails = [line.strip() for line in out.splitlines() if line.strip().startswith("[FAIL]")]
        assert len(headings) == 1 and fails, out
        lines = [f"{headings[0]} {fails[0]}"]
    else:
        lines = [line for line in err.splitlines() if line.strip()]
        assert len(lines) == 1, err
    for pattern in patterns:
        assert re.search(pattern, lines[0]), (pattern, lines[0])
    return lines[0]


def snapshot(folder: Path) -> dict[str, bytes]:
    """Every file under `folder` by relative path, with its bytes."""
    return {str(p.relative_to(folder)): p.read_bytes() for p in folder.rglob("*") if p.is_file()}


@contextmanager
def no_hang(seconds: int = 20) -> Iterator[None]:
    """Fail instead of waiting for ever (a reader blocked on a FIFO)."""

    def expire(signum: int, frame: object) -> None:
        raise AssertionError(f"blocked for {seconds} s")

    previous = signal.signal(signal.SIGALRM, expire)
    signal.alarm(seconds)
    try:
        yield
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, previous)


def tampered(path: Path, robot: Robot, trajectory: Trajectory, /, **fields: str) -> Path:
    """The clip written with some fields of its metadata record replaced (CRCs stay valid)."""
    original = clip_module._metadata_record
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(clip_module, "_metadata_record", lambda t: {**original(t), **fields})
        return write(path, trajectory, robot)


def free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return probe.getsockname()[1]
