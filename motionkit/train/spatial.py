"""Quaternion helpers in JAX, (w, x, y, z) order as everywhere in motionkit and MuJoCo."""

from __future__ import annotations

import jax
import jax.numpy as jnp


def quat_to_matrix(q: jax.Array) -> jax.Array:
    w, x, y, z = q
    return jnp.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
            [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
            [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
        ]
    )


def quat_mul(a: jax.Array, b: jax.Array) -> jax.Array:
    aw, ax, ay, az = a
    bw, bx, by, bz = b
    return jnp.array(
        [
            aw * bw - ax * bx - ay * by - az * bz,
            aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw,
        ]
    )


def facing_angle(rotation: jax.Array, forward: jax.Array) -> jax.Array:
    """Yaw [rad] of the robot's forward axis (given in the base frame) in the world."""
    facing = rotation @ forward
    return jnp.arctan2(facing[1], facing[0])


def remove_heading(q: jax.Array, forward: jax.Array) -> jax.Array:
    """The orientation turned about world z so that the forward axis has the yaw it has at the
    identity orientation (as motionkit.dataset.amp.remove_heading), with w >= 0."""
    heading = facing_angle(quat_to_matrix(q), forward) - jnp.arctan2(forward[1], forward[0])
    turn = jnp.array([jnp.cos(heading / 2), 0.0, 0.0, -jnp.sin(heading / 2)])
    out = quat_mul(turn, q)
    return jnp.where(out[0] < 0, -out, out)
