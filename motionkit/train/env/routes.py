"""Routes across a course's tile: each waypoint lies `waypoint_distance` on from the one before
(3-D, as on flat ground), in a direction within ROUTE_SPREAD of straight out from the tile's
centre, so that a route from the pad crosses the tile (and a pit's moat); one that would leave
the tile's inner square (`bound` about its centre) turns back through the middle.

A ground waypoint stands on footing: on a stones tile at the middle of a stone (or on the pad),
elsewhere on the first solid ground at or beyond the point drawn along the way, at least
FOOTING_BEHIND metres past a hole's far edge, so that a route over a pit crosses it and waits
on the far side. Air waypoints lie `air_height` above the surface (a hole read as its rim), as
on flat ground.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp

from motionkit.train.config import EnvConfig
from motionkit.train.env.terrain import Terrain, over_hole, surface_at
from motionkit.train.env.tiles import snap_to_stone

ROUTE_SPREAD = jnp.deg2rad(30.0)  # directions within this of straight out from the centre
OUT_FROM = 0.3  # m: nearer the centre than this, "out" is a random direction
SEARCH = 2.5  # m searched beyond a drawn ground waypoint for footing (a hard moat's diagonal)
SEARCH_STEP = 0.1  # m
FOOTING_BEHIND = 0.2  # m of solid ground behind a ground waypoint along its way
FOOTPRINT = 0.1  # m: the ground this far about a waypoint is solid too


def footing(
    terrain: Terrain,
    xy: jax.Array,
    way: jax.Array,
    centre: jax.Array,
    d: jax.Array,
    stones: jax.Array,
) -> jax.Array:
    """The first place to stand at or beyond `xy` along the unit direction `way` (within
    SEARCH); on a stones tile (`stones`, of difficulty d, centred at `centre`), snapped to the
    middle of a stone. The tile's centre when there is none."""
    steps = jnp.arange(round(SEARCH / SEARCH_STEP) + 1) * SEARCH_STEP
    points = xy + steps[:, None] * way
    snapped = centre + snap_to_stone(points - centre, d, jnp)
    points = jnp.where(stones, snapped, points)
    behind = jnp.where(stones, points, points - FOOTING_BEHIND * way)
    around = jnp.array([[0.0, 0.0], [1, 0], [-1, 0], [0, 1], [0, -1]]) * FOOTPRINT
    spots = jnp.concatenate([points[:, None] + around, behind[:, None]], axis=1)
    solid = ~jnp.any(over_hole(terrain, spots), axis=1)
    first = jnp.argmax(solid)
    return jnp.where(solid[first], points[first], centre)


def course_waypoint(
    key: jax.Array,
    previous: jax.Array,
    centre: jax.Array,
    d: jax.Array,
    stones: jax.Array,
    config: EnvConfig,
    terrain: Terrain,
    bound: float,
    air_share: jax.Array | float,
) -> jax.Array:
    """A waypoint (3,) following `previous` on the tile centred at `centre` (x, y) of
    difficulty d (a stones tile where `stones`); in the air with probability `air_share`."""
    k_air, k_lift, k_dist, k_angle, k_out = jax.random.split(key, 5)
    air = jax.random.uniform(k_air) < air_share
    low, high = config.air_height
    lift = jnp.where(air, jax.random.uniform(k_lift, minval=low, maxval=high), config.ground_height)
    distance = jax.random.uniform(
        k_dist, minval=config.waypoint_distance[0], maxval=config.waypoint_distance[1]
    )
    climb = lift - (previous[2] - surface_at(terrain, previous[:2]))
    horizontal = jnp.sqrt(jnp.maximum(distance**2 - climb**2, 0.0))
    offset = previous[:2] - centre
    anywhere = jax.random.uniform(k_out, minval=-jnp.pi, maxval=jnp.pi)
    out = jnp.where(jnp.linalg.norm(offset) > OUT_FROM, jnp.arctan2(offset[1], offset[0]), anywhere)
    angle = out + jax.random.uniform(k_angle, minval=-ROUTE_SPREAD, maxval=ROUTE_SPREAD)
    way = jnp.array([jnp.cos(angle), jnp.sin(angle)])
    leaves = jnp.any(jnp.abs(previous[:2] + horizontal * way - centre) > bound)
    way = jnp.where(leaves, -way, way)
    xy = jnp.clip(previous[:2] + horizontal * way, centre - bound, centre + bound)
    xy = jnp.where(air, xy, footing(terrain, xy, way, centre, d, stones))
    return jnp.array([xy[0], xy[1], surface_at(terrain, xy) + lift])
