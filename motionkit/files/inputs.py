"""Opening input files: regular files only, opened without blocking (a FIFO, socket, device or
folder is refused, never waited on), text as strict UTF-8 naming the line of a bad byte.

`what` names the input in messages: "{path}: cannot read {what} (...)"."""

from __future__ import annotations

import codecs
import os
import stat
from pathlib import Path
from typing import BinaryIO

from motionkit.core.errors import MotionkitError

_KINDS = (
    (stat.S_ISDIR, "a folder"),
    (stat.S_ISFIFO, "a FIFO"),
    (stat.S_ISSOCK, "a socket"),
    (stat.S_ISCHR, "a character device"),
    (stat.S_ISBLK, "a block device"),
)


def open_input(path: Path | str, error: type[MotionkitError], what: str) -> BinaryIO:
    """`path` open for binary reading, or `error` naming it: missing, unreadable, or not a
    regular file."""
    path = Path(path)
    flags = os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_BINARY", 0)
    try:
        fd = os.open(path, flags)
    except OSError as exc:
        raise error(f"{path}: cannot read {what} ({exc.strerror})") from None
    mode = os.fstat(fd).st_mode
    if not stat.S_ISREG(mode):
        os.close(fd)
        kind = next((name for test, name in _KINDS if test(mode)), "not a plain file")
        raise error(f"{path}: cannot read {what}: {kind}, not a regular file")
    return os.fdopen(fd, "rb")


def read_bytes(path: Path | str, error: type[MotionkitError], what: str) -> bytes:
    """The whole content of a regular file (see `open_input`)."""
    with open_input(path, error, what) as handle:
        try:
            return handle.read()
        except OSError as exc:
            raise error(f"{path}: cannot read {what} ({exc.strerror})") from None


def read_text(path: Path | str, error: type[MotionkitError], what: str, empty: bool = False) -> str:
    """A UTF-8 text file (a leading byte-order mark is dropped); an empty file (unless `empty`),
    NUL bytes (binary data) or bytes that are not UTF-8 are refused, naming the line."""
    data = read_bytes(path, error, what)
    if not empty and not data.strip():
        raise error(f"{path}: cannot read {what}: the file is empty")
    nul = data.find(b"\0")
    if nul >= 0:
        line = data.count(b"\n", 0, nul) + 1
        raise error(f"{path} line {line}: cannot read {what}: a NUL byte (binary data)")
    if data.startswith(codecs.BOM_UTF8):
        data = data[len(codecs.BOM_UTF8) :]
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as exc:
        line = data.count(b"\n", 0, exc.start) + 1
        raise error(
            f"{path} line {line}: cannot read {what}: byte 0x{data[exc.start]:02x} is not UTF-8 "
            "(binary data, or text in another encoding: save it as UTF-8)"
        ) from None
