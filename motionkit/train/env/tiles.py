"""The tiles of a course: their shapes by difficulty d in [0, 1] (level 0 to the top level) and
their heights, in metres, about the tile's centre. Every tile has a flat pad of half side PAD in
the middle, at the datum (0), where episodes start.

- flat: the datum everywhere.
- rough: blocks of BLOCK metres raised by uniform random heights from 0 up to
  `bump_height(d)`, 2 cm (small) to 12 cm (ankle-high: iRonCub's ankle is about 10 cm up).
- stones: square stones of side `stone_side(d)` (0.5 to 0.3 m) in a grid around the pad,
  `stone_gap(d)` apart (0.1 m, which a step spans, to 0.8 m, which none can: iRonCub's legs
  are about 0.5 m long), both rounded to whole grid cells (`stone_grid`), their tops
  `stone_jitter(d)` about the datum, the gaps HOLE deep.
- pits: a square moat round the pad from PIT_INNER out, `pit_width(d)` wide (0.3 m, a step, to
  1.5 m, wider than any step) and `pit_depth(d)` deep (0.2 m to 1 m, deeper than a leg), so
  that the hard end cannot be walked: only flown over.

The shape functions are plain arithmetic, for numpy and JAX alike (the routes snap waypoints
onto the stones with `snap_to_stone`, the numpy tiles place them with `stone_axis`).
"""

from __future__ import annotations

from types import ModuleType
from typing import Any

import numpy as np

from motionkit.train.env.terrain import CELL

PAD = 0.6  # m, half side of the flat pad in the middle of each tile
BLOCK = 0.3  # m, side of a block of rough ground
HOLE = 1.0  # m, depth of the gaps between stones
PIT_INNER = 1.0  # m, half side of the ground the moat of a pit tile surrounds
FOOT_MARGIN = 0.15  # m: a waypoint on the pad's column stays this far inside its edge


def bump_height(d: Any) -> Any:
    return 0.02 + 0.10 * d


def stone_side(d: Any) -> Any:
    return 0.5 - 0.2 * d


def stone_gap(d: Any) -> Any:
    return 0.1 + 0.7 * d


def stone_jitter(d: Any) -> Any:
    return 0.05 * d


def pit_width(d: Any) -> Any:
    return 0.3 + 1.2 * d


def pit_depth(d: Any) -> Any:
    return 0.2 + 0.8 * d


def stone_grid(d: Any, xp: ModuleType = np) -> tuple[Any, Any]:
    """(side, gap) of the stones at difficulty d, each a whole number of grid cells: the
    stones' edges lie on grid points, where the bilinear heights change from stone to gap."""
    return xp.round(stone_side(d) / CELL) * CELL, xp.round(stone_gap(d) / CELL) * CELL


def stone_axis(v: np.ndarray, d: float) -> tuple[np.ndarray, np.ndarray]:
    """Along one axis of a stones tile (v: coordinates about its centre): whether v lies in a
    column of stones (the pad's column, |v| <= PAD, included; edges included) and that
    column's index (0: the pad's, +-k: the k-th beyond it)."""
    side, gap = stone_grid(d)
    period, edge = side + gap, 1e-6
    beyond = np.abs(v) - PAD - gap  # from the near edge of the first stone out
    ring = np.floor(np.maximum(beyond + edge, 0.0) / period)
    solid = (np.abs(v) <= PAD) | ((beyond >= -edge) & (beyond - ring * period <= side + edge))
    index = np.where(np.abs(v) <= PAD, 0, np.sign(v) * (ring + 1)).astype(int)
    return solid, index


def snap_to_stone(v: Any, d: Any, xp: ModuleType = np) -> Any:
    """A coordinate near v (about a stones tile's centre, along one axis) of a place to stand:
    v itself on the pad's column but FOOT_MARGIN from its edge, else the middle of the nearest
    column of stones beyond the pad (a waypoint never stops at the pad's edge)."""
    side, gap = stone_grid(d, xp)
    period, first = side + gap, PAD + gap + side / 2
    ring = xp.maximum(xp.round((xp.abs(v) - first) / period), 0.0)
    stone = xp.where(v < 0, -1.0, 1.0) * (first + ring * period)
    return xp.where(xp.abs(v) <= PAD - FOOT_MARGIN, v, stone)


def heights(kind: str, x: np.ndarray, y: np.ndarray, d: float, rng: np.random.Generator) -> Any:
    """Heights of a tile of `kind` at points (x, y) about its centre, difficulty d; the pad
    (|x|, |y| <= PAD) is at the datum. Rough ground and stones draw from `rng`."""
    pad = np.maximum(np.abs(x), np.abs(y)) <= PAD
    extent = float(max(np.abs(x).max(), np.abs(y).max(), PAD))
    if kind == "rough":
        count = int(np.ceil(extent / BLOCK)) + 1
        table = rng.uniform(0.0, bump_height(d), (2 * count, 2 * count))
        column = np.floor(x / BLOCK).astype(int) + count
        row = np.floor(y / BLOCK).astype(int) + count
        tile = table[row, column]
    elif kind == "stones":
        on_x, column = stone_axis(x, d)
        on_y, row = stone_axis(y, d)
        count = int(np.ceil(extent / sum(stone_grid(d)))) + 1
        tops = rng.uniform(-1.0, 1.0, (2 * count + 1, 2 * count + 1)) * stone_jitter(d)
        tile = np.where(on_x & on_y, tops[row + count, column + count], -HOLE)
    elif kind == "pits":
        ring = np.maximum(np.abs(x), np.abs(y))
        moat = (ring > PIT_INNER) & (ring < PIT_INNER + pit_width(d))
        tile = np.where(moat, -pit_depth(d), 0.0)
    elif kind == "flat":
        tile = np.zeros_like(x)
    else:
        raise ValueError(f"no tile kind {kind!r}")
    return np.where(pad, 0.0, tile)
