"""Terrain as one height grid: the MJCF heightfield the robot collides with (MuJoCo C and MJX
alike) and the source of every height the task reads (`height_at`, bilinear; mjx.ray does not
hit heightfields).

A `Terrain` is a regular grid of heights [m] centred on the world origin, row = y, column = x
(MuJoCo's heightfield layout). Flat ground is the floor plane of the robot's MJCF (its grid only
serves `height_at`). A course (`motionkit.train.env.courses`) has a datum: the height of its
pads and of the rims of its pits and gaps. Ground GAP_DEPTH or more below it is a hole, and
`surface_at` reads a hole as the datum: a base that sinks into a pit is that much lower above
the ground it should be on (a fall), and a waypoint over a pit is high above its rim, not its
floor.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
from flax import struct

CELL = 0.1  # m, heightfield resolution
GAP_DEPTH = 0.1  # m: ground this far below the datum is a hole (a pit or a gap between stones)


@struct.dataclass
class Terrain:
    heights: jax.Array  # (rows = y, columns = x) [m]
    cell: float = struct.field(pytree_node=False, default=CELL)
    # the height of the course's pads and rims (None: no holes, as on flat ground)
    datum: float | None = struct.field(pytree_node=False, default=None)

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


def surface_at(terrain: Terrain, xy: jax.Array) -> jax.Array:
    """The ground a robot should be on at xy: the height, but the datum over a hole (ground
    GAP_DEPTH or more below the datum); the height itself without a datum."""
    height = height_at(terrain, xy)
    if terrain.datum is None:
        return height
    return jnp.where(height < terrain.datum - GAP_DEPTH, terrain.datum, height)


def over_hole(terrain: Terrain, xy: jax.Array) -> jax.Array:
    """Whether xy lies over a hole: ground GAP_DEPTH or more below the datum."""
    if terrain.datum is None:
        return jnp.zeros(xy.shape[:-1], bool)
    return height_at(terrain, xy) < terrain.datum - GAP_DEPTH


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
