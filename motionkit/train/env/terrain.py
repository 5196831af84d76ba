"""Terrains as height grids: flat ground, or tiles of rough ground, stepping stones and pits.

A `Terrain` is a regular grid of heights [m] centred on the world origin, row = y, column = x
(MuJoCo's heightfield layout). The same array becomes the MJCF heightfield the robot collides
with and feeds `height_at`, the bilinear height sampler of the observations and rewards
(mjx.ray does not hit heightfields). Flat ground is the floor plane of the robot's MJCF.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
from flax import struct

CELL = 0.1  # m, heightfield resolution
TILE = 4.0  # m, side of one terrain tile
PAD = 0.6  # m, half side of the flat pad in the middle of each tile (spawn area)
KINDS = ("flat", "rough", "stones", "pits")


@struct.dataclass
class Terrain:
    heights: jax.Array  # (rows = y, columns = x) [m]
    cell: float = struct.field(pytree_node=False, default=CELL)

    @property
    def half_extent(self) -> tuple[float, float]:
        rows, cols = self.heights.shape
        return (cols - 1) * self.cell / 2, (rows - 1) * self.cell / 2


def flat(size: float = 2.0) -> Terrain:
    """Zero heights (the floor plane; the grid only serves `height_at`)."""
    return Terrain(jnp.zeros((3, 3)), cell=size / 2)


def height_at(terrain: Terrain, xy: jax.Array) -> jax.Array:
    """Bilinear terrain height at points xy (..., 2); outside the grid, the nearest edge."""
    half_x, half_y = terrain.half_extent
    rows, cols = terrain.heights.shape
    u = jnp.clip((xy[..., 0] + half_x) / terrain.cell, 0.0, cols - 1.0)
    v = jnp.clip((xy[..., 1] + half_y) / terrain.cell, 0.0, rows - 1.0)
    c0 = jnp.clip(jnp.floor(u).astype(jnp.int32), 0, cols - 2)
    r0 = jnp.clip(jnp.floor(v).astype(jnp.int32), 0, rows - 2)
    fu, fv = u - c0, v - r0
    h = terrain.heights
    top = (1 - fu) * h[r0, c0] + fu * h[r0, c0 + 1]
    bottom = (1 - fu) * h[r0 + 1, c0] + fu * h[r0 + 1, c0 + 1]
    return (1 - fv) * top + fv * bottom


def tile_centres(size: float) -> np.ndarray:
    """(n, 2) centres of the tiles of a terrain of side `size` (the spawn points)."""
    count = max(1, int(size // TILE))
    offsets = (np.arange(count) - (count - 1) / 2) * TILE
    return np.array([(x, y) for y in offsets for x in offsets])


def _tile(kind: str, rng: np.random.Generator, n: int) -> np.ndarray:
    """Heights of one n x n tile of the given kind (a flat pad in the middle is added later)."""
    xs = (np.arange(n) - (n - 1) / 2) * CELL
    x, y = np.meshgrid(xs, xs)
    if kind == "rough":  # +-4 cm bumps, smoothed over about 0.3 m
        coarse = rng.uniform(-0.04, 0.04, (n // 3 + 2, n // 3 + 2))
        return np.kron(coarse, np.ones((3, 3)))[:n, :n]
    if kind == "stones":  # 0.3 m stones 0.5 m apart over a 0.5 m deep gap
        period, stone = 0.5, 0.3
        on_x = np.abs((x + period / 2) % period - period / 2) < stone / 2
        on_y = np.abs((y + period / 2) % period - period / 2) < stone / 2
        return np.where(on_x & on_y, rng.uniform(-0.03, 0.03), -0.5)
    if kind == "pits":  # a ring of 0.4-0.8 m wide, 0.3-0.6 m deep pits
        ring = np.maximum(np.abs(x), np.abs(y))
        inner = rng.uniform(0.9, 1.2)
        width = rng.uniform(0.4, 0.8)
        return np.where((ring > inner) & (ring < inner + width), -rng.uniform(0.3, 0.6), 0.0)
    return np.zeros_like(x)


def mixed(size: float, seed: int) -> Terrain:
    """A square terrain of side `size` tiled with flat, rough, stepping-stone and pit tiles
    (each tile has a flat pad in the middle where episodes start)."""
    rng = np.random.default_rng(seed)
    count = max(1, int(size // TILE))
    n = round(TILE / CELL)
    grid = np.zeros((count * n + 1, count * n + 1))
    xs = (np.arange(n) - (n - 1) / 2) * CELL
    pad = np.maximum(*np.meshgrid(np.abs(xs), np.abs(xs))) <= PAD
    for row in range(count):
        for col in range(count):
            kind = KINDS[(row * count + col) % len(KINDS)] if count > 1 else "rough"
            tile = np.where(pad, 0.0, _tile(kind, rng, n))
            grid[row * n : (row + 1) * n, col * n : (col + 1) * n] = tile
    grid[-1, :], grid[:, -1] = grid[-2, :], grid[:, -2]
    return Terrain(jnp.asarray(grid, dtype=jnp.float32))


def hfield_mjcf(terrain: Terrain, thickness: float = 0.5) -> tuple[str, str]:
    """The MJCF <asset> heightfield and the world <geom> using it, for this terrain."""
    heights = np.asarray(terrain.heights, dtype=float)
    low, high = float(heights.min()), float(heights.max())
    span = max(high - low, 1e-3)
    rows, cols = heights.shape
    half_x, half_y = terrain.half_extent
    # MJCF's elevation attribute lists the rows from +y down to -y (the stored grid is flipped)
    data = " ".join(f"{v:.5f}" for v in ((heights - low) / span)[::-1].ravel())
    asset = (
        f'<hfield name="terrain" nrow="{rows}" ncol="{cols}" '
        f'size="{half_x} {half_y} {span} {thickness}" elevation="{data}"/>'
    )
    geom = (
        f'<geom name="terrain" type="hfield" hfield="terrain" pos="0 0 {low}" '
        'rgba="0.6 0.6 0.55 1"/>'
    )
    return asset, geom
