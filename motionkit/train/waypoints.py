"""Waypoint routes on the ground and in the air: each new waypoint lies `waypoint_distance`
from the previous one (3-D), on the ground (base at `ground_height` above the terrain) or, with
probability `air_probability`, in the air (base `air_height` above the terrain)."""

from __future__ import annotations

import jax
import jax.numpy as jnp

from motionkit.train.config import EnvConfig
from motionkit.train.terrain import Terrain, height_at


def lift_of(terrain: Terrain, point: jax.Array) -> jax.Array:
    """Height of a point above the terrain below it."""
    return point[2] - height_at(terrain, point[:2])


def next_waypoint(
    key: jax.Array, previous: jax.Array, config: EnvConfig, terrain: Terrain, bound: float
) -> jax.Array:
    """A waypoint (3,) following `previous`; x and y are kept within +-bound."""
    k_air, k_lift, k_dist, k_angle = jax.random.split(key, 4)
    air = jax.random.uniform(k_air) < config.air_probability
    low, high = config.air_height
    lift = jnp.where(air, jax.random.uniform(k_lift, minval=low, maxval=high), config.ground_height)
    distance = jax.random.uniform(
        k_dist, minval=config.waypoint_distance[0], maxval=config.waypoint_distance[1]
    )
    climb = lift - lift_of(terrain, previous)
    horizontal = jnp.sqrt(jnp.maximum(distance**2 - climb**2, 0.0))
    angle = jax.random.uniform(k_angle, minval=-jnp.pi, maxval=jnp.pi)
    xy = previous[:2] + horizontal * jnp.array([jnp.cos(angle), jnp.sin(angle)])
    xy = jnp.clip(xy, -bound, bound)
    return jnp.array([xy[0], xy[1], height_at(terrain, xy) + lift])


def reached(position: jax.Array, target: jax.Array, radius: float) -> jax.Array:
    return jnp.sum((target - position) ** 2) < radius**2
