"""Courses: the "terrain" scenario's height grid, tiles laid out as legged_gym lays them, a row
per level (from easy to hard, along y) and a column per kind (along x).

    layout = CourseLayout.of(config)          # levels, kinds, tile size, seed of an EnvConfig
    ground = build(layout)                    # the Terrain: one height grid, datum 0
    x, y = tile_centre(layout, level, kind)   # where an episode on that tile starts

Each tile is `tiles.heights` of its kind at difficulty level / (levels - 1), drawn from the
layout's seed. Evaluations run on courses of seeds training does not use: `held_out(layout, n)`
is the course of seed HELD_OUT + n. `clip_terrain` is what a clip records of the course under
its robot (the layout and tile, and that part of the grid), for the viewer and the renderer.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, replace
from typing import Any

import jax.numpy as jnp
import numpy as np

from motionkit.core.errors import TrainError
from motionkit.train.config import TERRAIN_KINDS, EnvConfig
from motionkit.train.env import tiles
from motionkit.train.env.terrain import CELL, Terrain

HELD_OUT = 1_000_000  # course seeds from here on are the evaluations' (training uses fewer)
DATUM = 0.0  # m: the height of every pad and of the rims of the pits and gaps


@dataclass(frozen=True)
class CourseLayout:
    """What a course is made of: `levels` rows of `kinds` tiles, `tile_size` metres square (a
    whole number of grid cells), their random parts drawn from `seed`."""

    levels: int
    kinds: tuple[str, ...]
    tile_size: float
    seed: int

    @classmethod
    def of(cls, config: EnvConfig) -> CourseLayout:
        return cls(config.terrain_levels, tuple(config.terrain_kinds), config.tile_size,
                   config.terrain_seed)  # fmt: skip

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> CourseLayout:
        return cls(int(data["levels"]), tuple(data["kinds"]), float(data["tile_size"]),
                   int(data["seed"]))  # fmt: skip

    def to_dict(self) -> dict[str, Any]:
        return asdict(self) | {"kinds": list(self.kinds)}

    @property
    def cells(self) -> int:
        """Grid cells along a tile's side."""
        return round(self.tile_size / CELL)

    def difficulty(self, level: Any) -> Any:
        """Level 0 to the top level as 0 to 1 (0 when there is one level)."""
        return level / max(self.levels - 1, 1)


def tile_centre(layout: CourseLayout, level: Any, kind: Any) -> tuple[Any, Any]:
    """(x, y) of the centre of the tile of `level` and kind index `kind` (numbers or arrays)."""
    tile = layout.cells * CELL
    return (kind - (len(layout.kinds) - 1) / 2) * tile, (level - (layout.levels - 1) / 2) * tile


def build_heights(layout: CourseLayout) -> np.ndarray:
    """The course's height grid (rows = y, columns = x) [m], centred on the origin."""
    n, count = layout.cells, len(layout.kinds)
    rows, cols = layout.levels * n + 1, count * n + 1
    xs = np.arange(cols) * CELL - count * n * CELL / 2
    ys = np.arange(rows) * CELL - layout.levels * n * CELL / 2
    grid = np.zeros((rows, cols))
    rng = np.random.default_rng(layout.seed)
    for level in range(layout.levels):
        for k, kind in enumerate(layout.kinds):
            r0, c0 = level * n, k * n
            r1, c1 = r0 + n + (level == layout.levels - 1), c0 + n + (k == count - 1)
            cx, cy = tile_centre(layout, level, k)
            # about the tile's centre, rounded to the micrometre: a point on a pad's or a
            # stone's edge stays on it
            x, y = np.round(np.meshgrid(xs[c0:c1] - cx, ys[r0:r1] - cy), 6)
            d = layout.difficulty(level)
            grid[r0:r1, c0:c1] = DATUM + tiles.heights(kind, x, y, d, rng)
    return grid


def build(layout: CourseLayout) -> Terrain:
    """The course as a Terrain (float32 heights, datum DATUM)."""
    return Terrain(jnp.asarray(build_heights(layout), jnp.float32), datum=DATUM)


def held_out(layout: CourseLayout, number: int = 0) -> CourseLayout:
    """The same course with seed HELD_OUT + number: one that training did not use."""
    return replace(layout, seed=HELD_OUT + number)


def parse_tile(text: str, layout: CourseLayout) -> tuple[int, int]:
    """'KIND[:LEVEL]' as (kind index, level) of the layout; without a level, the hardest. A
    TrainError naming what is wrong."""
    kind, _, level_text = text.partition(":")
    if kind not in layout.kinds:
        known = ", ".join(layout.kinds)
        more = "" if kind not in TERRAIN_KINDS else " (not among the config's terrain_kinds)"
        raise TrainError(f"--terrain {text!r}: no kind {kind!r}{more}; expected one of {known}")
    try:
        level = int(level_text) if level_text else layout.levels - 1
    except ValueError:
        level = -1
    if not 0 <= level < layout.levels:
        raise TrainError(
            f"--terrain {text!r}: the level should be a whole number from 0 to "
            f"{layout.levels - 1} (the config's terrain_levels is {layout.levels})"
        )
    return layout.kinds.index(kind), level


def clip_terrain(
    layout: CourseLayout, level: int, kind: int, low: np.ndarray, high: np.ndarray
) -> dict[str, Any]:
    """What a clip records of its course: the layout, the tile (kind, level) and the grid's
    heights [m] over the box from `low` to `high` (x, y) [m], within the course: rows along y
    from `origin`, a point every `cell` metres."""
    heights = build_heights(layout)
    rows, cols = heights.shape
    half = np.array([cols - 1, rows - 1]) * CELL / 2
    first = np.clip(np.floor((np.asarray(low) + half) / CELL).astype(int), 0, [cols - 1, rows - 1])
    last = np.clip(np.ceil((np.asarray(high) + half) / CELL).astype(int), 0, [cols - 1, rows - 1])
    part = heights[first[1] : last[1] + 1, first[0] : last[0] + 1]
    origin = first * CELL - half
    return {
        "course": layout.to_dict(),
        "kind": layout.kinds[kind],
        "level": int(level),
        "cell": CELL,
        "origin": [round(float(v), 4) for v in origin],
        "heights": np.round(part, 4).tolist(),
    }
