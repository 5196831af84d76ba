"""Waypoint routes on the ground and in the air: each new waypoint lies `waypoint_distance`
from where it is drawn from (3-D), on the ground (base at `ground_height` above the terrain) or,
with probability `air_share`, in the air (base `air_height` above the terrain). A waypoint that
is not reached within its deadline is replaced; the share of air waypoints can rise over the
first iterations of training (a curriculum). Heights are above the surface
(`terrain.surface_at`: on a course, a hole counts as its rim); routes across a course's tiles
are drawn by `motionkit.train.env.routes`."""

from __future__ import annotations

import jax
import jax.numpy as jnp

from motionkit.train.config import EnvConfig
from motionkit.train.env.terrain import Terrain, surface_at


def lift_of(terrain: Terrain, point: jax.Array) -> jax.Array:
    """Height of a point above the surface below it."""
    return point[2] - surface_at(terrain, point[:2])


def next_waypoint(
    key: jax.Array,
    previous: jax.Array,
    config: EnvConfig,
    terrain: Terrain,
    bound: float,
    air_share: jax.Array | float,
    heading: jax.Array | float = 0.0,
) -> jax.Array:
    """A waypoint (3,) following `previous`; in the air with probability `air_share`; x and y
    are kept within +-bound. Its direction lies within +-config.waypoint_angle degrees of
    `heading` (the robot's yaw [rad]); at 180, any direction."""
    k_air, k_lift, k_dist, k_angle = jax.random.split(key, 4)
    air = jax.random.uniform(k_air) < air_share
    low, high = config.air_height
    lift = jnp.where(air, jax.random.uniform(k_lift, minval=low, maxval=high), config.ground_height)
    distance = jax.random.uniform(
        k_dist, minval=config.waypoint_distance[0], maxval=config.waypoint_distance[1]
    )
    climb = lift - lift_of(terrain, previous)
    horizontal = jnp.sqrt(jnp.maximum(distance**2 - climb**2, 0.0))
    if config.waypoint_angle >= 180.0:
        angle = jax.random.uniform(k_angle, minval=-jnp.pi, maxval=jnp.pi)
    else:
        cone = jnp.deg2rad(config.waypoint_angle)
        angle = heading + jax.random.uniform(k_angle, minval=-cone, maxval=cone)
    xy = previous[:2] + horizontal * jnp.array([jnp.cos(angle), jnp.sin(angle)])
    xy = jnp.clip(xy, -bound, bound)
    return jnp.array([xy[0], xy[1], surface_at(terrain, xy) + lift])


def in_air(terrain: Terrain, target: jax.Array, config: EnvConfig) -> jax.Array:
    """Whether waypoint `target` is an air one: its height above the terrain is nearer the air
    waypoints' lowest than the ground waypoints' base height."""
    return lift_of(terrain, target) > 0.5 * (config.ground_height + config.air_height[0])


def reached(position: jax.Array, target: jax.Array, radius: float) -> jax.Array:
    return jnp.sum((target - position) ** 2) < radius**2


def deadline_steps(
    position: jax.Array, target: jax.Array, config: EnvConfig, v_desired: float
) -> jax.Array:
    """Control steps allowed to reach `target` from `position`: timeout_factor * distance /
    v_desired + timeout_extra seconds (no limit without `waypoint_timeout`)."""
    if not config.waypoint_timeout:
        return jnp.array(jnp.iinfo(jnp.int32).max, jnp.int32)
    distance = jnp.linalg.norm(target - position)
    seconds = config.timeout_factor * distance / v_desired + config.timeout_extra
    return jnp.ceil(seconds * config.control_hz).astype(jnp.int32)


def air_share(iteration: jax.Array | int, config: EnvConfig) -> jax.Array:
    """The chance of an air waypoint at a training iteration: air_probability, reached
    linearly from 0 over the first `air_curriculum` iterations."""
    if config.air_curriculum <= 0:
        return jnp.asarray(config.air_probability, jnp.float32)
    ramp = jnp.minimum(jnp.asarray(iteration, jnp.float32) / config.air_curriculum, 1.0)
    return config.air_probability * ramp
