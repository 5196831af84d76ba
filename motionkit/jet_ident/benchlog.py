"""Jet test-bench logs as CSV: one row per sample, SI units, checked row by row.

The file is UTF-8 text. Lines starting with `#` are comments; a comment `# key: value` becomes
an entry of `BenchLog.metadata`. The first other line is the header; it must name these columns
(in any order; further columns are ignored):

    time_s        time since the start of the log [s], strictly increasing, uniformly sampled
    throttle_pct  throttle command sent to the engine's ECU [%], 0 to 100
    thrust_n      thrust measured by the load cell [N]

A header cell is matched by its quantity and unit, without regard to case: `thrust_N`,
`Thrust [N]`, `thrust (newton)` and `thrust` all name the thrust in newtons; a column in another
unit (`thrust_kN`, `time [ms]`) is refused, naming it.

Errors name the file and the line (1-based, counting comments and the header). Thrust in the
wrong unit is caught by range: a value above MAX_THRUST_N is taken for grams (a P250 gives about
23,000 g), and a log whose thrust never exceeds KILONEWTON_CEILING while the throttle passes
KILONEWTON_THROTTLE is taken for kN (any engine's: even the smallest turbojets idle above 1 N,
and none gives 1,000 N).
"""

from __future__ import annotations

import csv
import io
import math
import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from motionkit.core.errors import JetIdentError
from motionkit.files.inputs import read_text
from motionkit.files.outputs import write_text_atomic

COLUMNS = ("time_s", "throttle_pct", "thrust_n")
# each column's quantity and the spellings of its unit
UNITS = {"time": ("s", "sec", "second", "seconds"), "throttle": ("pct", "%", "percent"),
         "thrust": ("n", "newton", "newtons")}  # fmt: skip
MAX_THRUST_N = 1000.0  # small turbojets give at most a few hundred newtons
MIN_THRUST_N = -50.0  # load-cell offset and ringing may dip below zero, not this far
KILONEWTON_CEILING = 1.0  # N; a running jet past KILONEWTON_THROTTLE gives more than this
KILONEWTON_THROTTLE = 10.0  # %
MAX_JITTER = 0.25  # a sample interval may differ from the median by this fraction


@dataclass(frozen=True)
class BenchLog:
    """One bench run: samples at a constant rate `1 / dt`."""

    time: np.ndarray  # [s]
    throttle: np.ndarray  # [%]
    thrust: np.ndarray  # [N]
    name: str = "log"
    metadata: dict[str, str] = field(default_factory=dict)

    @property
    def dt(self) -> float:
        return float(np.median(np.diff(self.time)))

    @property
    def samples(self) -> int:
        return len(self.time)

    @property
    def duration(self) -> float:
        return float(self.time[-1] - self.time[0])


def read_log(path: Path) -> BenchLog:
    """The checked log in `path`, or JetIdentError naming the file, the line and the problem.

    Args:
        path: the bench log, a UTF-8 CSV file (see the module doc for its format).

    Returns:
        The log, named by the file's stem: time [s], throttle [%] and thrust [N], each of
        shape (samples,), and the `# key: value` comments as metadata.

    Raises:
        JetIdentError: a file that cannot be read, or text `parse_log` refuses.
    """
    text = read_text(path, JetIdentError, "bench log")  # a regular file, UTF-8, never waited on
    return parse_log(text, str(path))


def parse_log(text: str, source: str = "<log>") -> BenchLog:
    """The checked log in CSV `text` (the format of the module doc).

    Args:
        text: the CSV text: `#` comments, a header naming time_s, throttle_pct and thrust_n,
            one row per sample.
        source: the name errors give for the text; its stem names the log.

    Returns:
        The log: time [s], throttle [%] and thrust [N], each of shape (samples,), and the
        `# key: value` comments as metadata.

    Raises:
        JetIdentError: naming `source` and the line: no header, a missing, repeated or
            wrong-unit column, fewer than 2 rows, a short row, a value that is not a finite
            number, time not increasing or not uniformly sampled, throttle outside 0-100 %,
            thrust out of range or apparently in grams or kN.
    """
    metadata: dict[str, str] = {}
    rows: list[tuple[int, list[str]]] = []
    header: list[str] | None = None
    header_line = 0
    for number, cells in _numbered_rows(text):
        first = cells[0].strip() if cells else ""
        if not cells or (len(cells) == 1 and not first):
            continue
        if first.startswith("#"):
            key, sep, value = ",".join(cells).lstrip("#").partition(":")
            if sep:
                metadata[key.strip()] = value.strip()
            continue
        if header is None:
            header, header_line = [c.strip() for c in cells], number
        else:
            rows.append((number, cells))
    if header is None:
        raise JetIdentError(f"{source}: no header line; expected columns {', '.join(COLUMNS)}")
    index = _columns(header, f"{source}: line {header_line}")
    if len(rows) < 2:
        raise JetIdentError(f"{source}: {len(rows)} data row(s); a log needs at least 2")
    values = np.empty((len(rows), 3))
    lines = np.array([n for n, _ in rows])
    for i, (number, cells) in enumerate(rows):
        if len(cells) < len(header):
            raise JetIdentError(
                f"{source}: line {number}: {len(cells)} value(s), the header has {len(header)}"
            )
        for j, column in enumerate(index):
            values[i, j] = _number(cells[column], source, number, COLUMNS[j])
    log = BenchLog(values[:, 0], values[:, 1], values[:, 2], Path(source).stem, metadata)
    check_log(log, source, lines)
    return log


def _columns(header: list[str], where: str) -> list[int]:
    """The header positions of time, throttle and thrust (see the module doc)."""
    found: dict[str, int] = {}
    for position, cell in enumerate(header):
        words = re.split(r"[\s_\[\]()]+", cell.strip().lower())
        quantity, unit = words[0], "".join(words[1:])
        if quantity not in UNITS:
            continue
        if unit and unit not in UNITS[quantity]:
            written = cell.strip()[len(quantity) :].strip(" _[]()")
            expected = {"time": "s", "throttle": "%", "thrust": "N"}[quantity]
            raise JetIdentError(f"{where}: column '{cell}' is in {written}; expected {expected}")
        if quantity in found:
            first = header[found[quantity]]
            raise JetIdentError(f"{where}: columns '{first}' and '{cell}' both give the {quantity}")
        found[quantity] = position
    missing = [c for c, quantity in zip(COLUMNS, UNITS, strict=True) if quantity not in found]
    if missing:
        raise JetIdentError(
            f"{where}: missing column(s) {', '.join(missing)}; the header has "
            f"{', '.join(header)}; expected {', '.join(COLUMNS)} (units s, %, N)"
        )
    return [found[quantity] for quantity in UNITS]


def check_log(log: BenchLog, source: str, lines: np.ndarray | None = None) -> None:
    """JetIdentError at the first line that breaks a rule of the format (see the module doc)."""

    def fail(i: int, message: str) -> None:
        where = f"line {int(lines[i])}" if lines is not None else f"row {i + 1}"
        raise JetIdentError(f"{source}: {where}: {message}")

    steps = np.diff(log.time)
    bad = np.flatnonzero(steps <= 0)
    if bad.size:
        i = bad[0] + 1
        fail(i, f"time {log.time[i]:g} s is not after the previous row's {log.time[i - 1]:g} s")
    dt = float(np.median(steps))
    bad = np.flatnonzero(np.abs(steps - dt) > MAX_JITTER * dt)
    if bad.size:
        i = bad[0] + 1
        fail(i, f"sample interval {steps[i - 1]:g} s; the log is sampled every {dt:g} s")
    bad = np.flatnonzero((log.throttle < 0) | (log.throttle > 100))
    if bad.size:
        fail(bad[0], f"throttle_pct {log.throttle[bad[0]]:g} is outside 0-100 %")
    bad = np.flatnonzero(log.thrust > MAX_THRUST_N)
    if bad.size:
        fail(
            bad[0],
            f"thrust_n {log.thrust[bad[0]]:g} is above {MAX_THRUST_N:g} N; is the column in "
            "grams? expected newtons",
        )
    bad = np.flatnonzero(log.thrust < MIN_THRUST_N)
    if bad.size:
        fail(bad[0], f"thrust_n {log.thrust[bad[0]]:g} is below {MIN_THRUST_N:g} N")
    top = int(np.argmax(log.thrust))
    if log.throttle.max() > KILONEWTON_THROTTLE and log.thrust[top] < KILONEWTON_CEILING:
        fail(
            top,
            f"thrust_n peaks at {log.thrust[top]:g} while the throttle reaches "
            f"{log.throttle.max():g} %; is the column in kN? expected newtons",
        )


def _numbered_rows(text: str):
    reader = csv.reader(io.StringIO(text))
    for cells in reader:
        yield reader.line_num, cells


def _number(cell: str, source: str, line: int, column: str) -> float:
    try:
        value = float(cell)
    except ValueError:
        message = f"{source}: line {line}: {column} '{cell.strip()}' is not a number"
        raise JetIdentError(message) from None
    if not math.isfinite(value):
        raise JetIdentError(f"{source}: line {line}: {column} is {cell.strip()}")
    return value


def format_log(log: BenchLog) -> str:
    """The CSV text of `log` (metadata as comments); `parse_log` reads it back."""
    out = io.StringIO()
    for key, value in log.metadata.items():
        out.write(f"# {key}: {value}\n")
    out.write(",".join(COLUMNS) + "\n")
    for t, u, f in zip(log.time, log.throttle, log.thrust, strict=True):
        out.write(f"{t:.4f},{u:.2f},{f:.3f}\n")
    return out.getvalue()


def write_log(path: Path, log: BenchLog) -> None:
    """Write `log` as CSV, all or nothing, and only if the text reads back as a valid log.

    An existing file is never replaced by one that `read_log` would refuse. The metadata are
    written as `# key: value` comments; time to 0.1 ms, throttle to 0.01 %, thrust to 1 mN.

    Args:
        path: the CSV file to write.
        log: the log: time [s], throttle [%], thrust [N], each of shape (samples,).

    Returns:
        None.

    Raises:
        JetIdentError: a log that breaks a rule of the format, before or after the CSV's
            rounding (nothing is written).
    """
    check_log(log, str(path))
    text = format_log(log)
    parse_log(text, f"{path} (not written)")  # what the CSV's rounding makes of it
    write_text_atomic(Path(path), text)
