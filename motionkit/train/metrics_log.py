"""Metrics logs: CSV files (always) and TensorBoard events (when `tensorboardX` is installed)."""

from __future__ import annotations

import csv
import math
from pathlib import Path
from typing import Any


class MetricsLog:
    """Rows of scalars per iteration into `<folder>/<name>.csv` and the TensorBoard writer."""

    def __init__(self, folder: Path, tensorboard: bool = True) -> None:
        self.folder = Path(folder)
        self.folder.mkdir(parents=True, exist_ok=True)
        self.columns: dict[str, list[str]] = {}
        self.writer: Any = None
        self.note = ""
        if tensorboard:
            try:
                from tensorboardX import SummaryWriter
            except ImportError:
                self.note = "TensorBoard events off: pip install tensorboardX"
            else:
                self.writer = SummaryWriter(str(self.folder / "tensorboard"))

    def write(self, name: str, iteration: int, metrics: dict[str, float]) -> None:
        path = self.folder / f"{name}.csv"
        if name not in self.columns:
            self.columns[name] = self._header(path, metrics)
        columns = self.columns[name]
        with path.open("a", newline="") as stream:
            row = {"iteration": iteration, **metrics}
            csv.writer(stream).writerow([_cell(row.get(c)) for c in columns])
        if self.writer is not None:
            for key, value in metrics.items():
                if value is not None and math.isfinite(value):
                    self.writer.add_scalar(f"{name}/{key}", value, iteration)
            self.writer.flush()

    def _header(self, path: Path, metrics: dict[str, float]) -> list[str]:
        """The columns of an existing file (a resumed run appends), or new ones."""
        if path.exists() and path.stat().st_size:
            with path.open(newline="") as stream:
                return next(csv.reader(stream))
        columns = ["iteration", *metrics]
        with path.open("w", newline="") as stream:
            csv.writer(stream).writerow(columns)
        return columns

    def close(self) -> None:
        if self.writer is not None:
            self.writer.close()


def _cell(value: Any) -> str:
    if value is None:
        return ""
    if isinstance(value, float):
        return f"{value:.6g}"
    return str(value)
