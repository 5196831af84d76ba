"""The terrain a clip records (a rollout or a play on a course: its metadata config "terrain",
written by `motionkit.train.env.courses.clip_terrain`), for the viewer and the renderer: a
regular grid of heights [m], rows along y from `origin`, a point every `cell` metres.

`clip_terrain(clip)` reads it (None when the clip has none), `grid_mesh` turns it into
triangles for the browser viewer, `hfield_data` into the rows of a MuJoCo heightfield for the
offscreen renderer. numpy only.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from motionkit.core.errors import ViewerError
from motionkit.viewer.sources import ClipInfo


@dataclass(frozen=True)
class TerrainPatch:
    """Heights (rows = y, columns = x) [m] of the grid points from `origin` (x, y) [m] on,
    `cell` metres apart; `label` names the course's tile ("pits, level 9")."""

    heights: np.ndarray
    origin: tuple[float, float]
    cell: float
    label: str = ""

    @property
    def size(self) -> tuple[float, float]:
        """(x, y) extent [m]."""
        rows, cols = self.heights.shape
        return (cols - 1) * self.cell, (rows - 1) * self.cell

    @property
    def centre(self) -> tuple[float, float]:
        width, depth = self.size
        return self.origin[0] + width / 2, self.origin[1] + depth / 2


def clip_terrain(clip: ClipInfo) -> TerrainPatch | None:
    """The terrain in the clip's metadata config; None without one; a ViewerError naming the
    clip when it is malformed."""
    value: Any = clip.metadata.config.get("terrain")
    if value is None:
        return None
    try:
        heights = np.asarray(value["heights"], dtype=float)
        origin = tuple(float(v) for v in value["origin"])
        cell = float(value["cell"])
        label = f"{value.get('kind', 'terrain')}, level {value.get('level', '?')}"
    except (KeyError, TypeError, ValueError) as exc:
        raise ViewerError(
            f"{clip.path}: metadata 'terrain' should hold 'heights' (rows of numbers), "
            f"'origin' [x, y] and 'cell' ({exc})"
        ) from exc
    ok = heights.ndim == 2 and min(heights.shape) >= 2 and len(origin) == 2 and cell > 0
    if not (ok and np.isfinite(heights).all() and np.isfinite(origin).all()):
        raise ViewerError(
            f"{clip.path}: metadata 'terrain' should be a grid of at least 2 x 2 finite "
            f"heights with a finite origin and a cell > 0, got {heights.shape} heights"
        )
    return TerrainPatch(heights, (origin[0], origin[1]), cell, label)


def grid_mesh(patch: TerrainPatch) -> tuple[np.ndarray, np.ndarray]:
    """Vertices (rows * cols, 3) [m] and faces (2 per cell, 3 vertex indices each, counter-
    clockwise seen from above) of the grid."""
    rows, cols = patch.heights.shape
    x = patch.origin[0] + np.arange(cols) * patch.cell
    y = patch.origin[1] + np.arange(rows) * patch.cell
    gx, gy = np.meshgrid(x, y)
    vertices = np.stack([gx, gy, patch.heights], axis=-1).reshape(-1, 3)
    corner = (np.arange(rows - 1)[:, None] * cols + np.arange(cols - 1)[None]).ravel()
    right, up = corner + 1, corner + cols
    faces = np.concatenate(
        [np.stack([corner, right, up + 1], 1), np.stack([corner, up + 1, up], 1)]
    )
    return vertices, faces


def hfield_data(patch: TerrainPatch) -> tuple[np.ndarray, float, float]:
    """(data, low, span): the heights as the data of a heightfield of MjSpec (0 to 1, rows
    from -y up, as `MjModel.hfield_data` holds them; MJCF's elevation attribute lists them the
    other way up), the lowest height and the span [m]."""
    low = float(patch.heights.min())
    span = max(float(patch.heights.max()) - low, 1e-3)
    return (patch.heights - low) / span, low, span
