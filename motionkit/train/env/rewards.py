"""Reward terms (pure functions of one environment's quantities) and their mix.

Task terms of the paper, with x_d the waypoint and p the base position (world frame):
    target    exp(-c1 |x_d - p|^2)
    velocity  exp(-c2 (v_d - s)^2), s = -d/dt |p - x_d| = v . (x_d - p) / |x_d - p|, the speed
              toward the waypoint (so the term peaks when approaching it at v_d)
    facing    cos of the angle between the robot's facing and the direction to the waypoint,
              both projected on the ground plane
    thrust    -sum_j (T_j / T_max)^2
and two terms of motionkit's own, off unless their weight is above 0:
    swing     sum over feet of min(h_f / h_s, 1) min(|u_f| / v_d, 1) while another foot is
              down, with h_f the sole's clearance and u_f its horizontal velocity: a foot that
              moves forward high enough, as in a step (a shuffle's soles stay near the floor)
    ground_thrust  -mean_j T_j / T_max on the way to a ground waypoint, 0 toward an air one:
              linear, so that the little thrust that steadies a walk costs what it uses (the
              thrust term's square makes 10 % of T_max cost 1 % of the full penalty)
Style: r_S = scale * -log(max(1 - sigmoid(D(chi_t, chi_t+1)), 1e-4)) = scale * min(softplus(D),
-log 1e-4) (the AMP reference's form, scale 2).
Total: w_G r_G + w_S r_S, with r_G = w_c target + w_v velocity + w_f facing + w_T thrust
(+ w_s swing + w_gt ground_thrust).
"""

from __future__ import annotations

import math

import jax
import jax.numpy as jnp

from motionkit.train.config import RewardConfig

EPS = 1e-6


def target_reward(position: jax.Array, target: jax.Array, c1: float) -> jax.Array:
    return jnp.exp(-c1 * jnp.sum((target - position) ** 2))


def approach_speed(position: jax.Array, velocity: jax.Array, target: jax.Array) -> jax.Array:
    """-d/dt |p - x_d| for a fixed waypoint: the velocity along the unit vector to it."""
    offset = target - position
    return jnp.dot(velocity, offset) / (jnp.linalg.norm(offset) + EPS)


def velocity_reward(
    position: jax.Array, velocity: jax.Array, target: jax.Array, v_desired: float, c2: float
) -> jax.Array:
    return jnp.exp(-c2 * (v_desired - approach_speed(position, velocity, target)) ** 2)


def facing_reward(facing: jax.Array, position: jax.Array, target: jax.Array) -> jax.Array:
    """Cosine between the facing (world vector) and the waypoint direction, in the xy plane."""
    a, b = facing[:2], (target - position)[:2]
    return jnp.dot(a, b) / (jnp.linalg.norm(a) * jnp.linalg.norm(b) + EPS)


def thrust_penalty(thrust: jax.Array, t_max: jax.Array | float) -> jax.Array:
    return -jnp.sum((thrust / t_max) ** 2)


def swing_reward(
    clearance: jax.Array, sole_speed: jax.Array, down: jax.Array, height: float, speed: float
) -> jax.Array:
    """Sum over feet of min(clearance / height, 1) * min(sole_speed / speed, 1), each foot
    counted while some other foot is down. clearance [m], sole_speed [m/s] (horizontal) and
    down (bool) are (feet,)."""
    lift = jnp.clip(clearance / height, 0.0, 1.0)
    pace = jnp.minimum(sole_speed / speed, 1.0)
    others_down = (jnp.sum(down) - down) > 0
    return jnp.sum(lift * pace * others_down)


def task_terms(
    position: jax.Array,
    velocity: jax.Array,
    facing: jax.Array,
    target: jax.Array,
    thrust: jax.Array,
    t_max: jax.Array | float,  # per jet or one for all
    config: RewardConfig,
) -> dict[str, jax.Array]:
    """The four task terms, unweighted."""
    return {
        "target": target_reward(position, target, config.c1),
        "velocity": velocity_reward(position, velocity, target, config.v_desired, config.c2),
        "facing": facing_reward(facing, position, target),
        "thrust": thrust_penalty(thrust, t_max),
    }


def task_reward(terms: dict[str, jax.Array], config: RewardConfig) -> jax.Array:
    """r_G: the weighted sum of the task terms."""
    return (
        config.w_target * terms["target"]
        + config.w_velocity * terms["velocity"]
        + config.w_facing * terms["facing"]
        + config.w_thrust * terms["thrust"]
        + config.w_swing * terms.get("swing", 0.0)
        + config.w_ground_thrust * terms.get("ground_thrust", 0.0)
    )


STYLE_FLOOR = 1e-4  # the least 1 - D that the style reward takes the log of


def style_reward(logit: jax.Array, scale: float) -> jax.Array:
    """scale * -log(max(1 - sigmoid(logit), 1e-4)), computed stably from softplus(logit)."""
    return scale * jnp.minimum(jax.nn.softplus(logit), -math.log(STYLE_FLOOR))


def total_reward(task: jax.Array, style: jax.Array, w_task: float, w_style: float) -> jax.Array:
    return w_task * task + w_style * style
