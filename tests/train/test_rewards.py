"""Each reward term against values computed by hand."""

import math

import jax.numpy as jnp
import numpy as np
import pytest

from motionkit.train.config import RewardConfig
from motionkit.train.env import rewards


def test_target_reward() -> None:
    value = rewards.target_reward(jnp.zeros(3), jnp.array([1.0, 2.0, 2.0]), 0.5)
    assert float(value) == pytest.approx(math.exp(-0.5 * 9.0), rel=1e-6)


def test_velocity_reward_uses_the_speed_toward_the_target() -> None:
    p, target, v = jnp.zeros(3), jnp.array([3.0, 4.0, 0.0]), jnp.array([0.6, 0.8, 5.0])
    # speed toward the target: (0.6 * 3 + 0.8 * 4) / 5 = 1.0 (the vertical 5 m/s is sideways)
    assert float(rewards.approach_speed(p, v, target)) == pytest.approx(1.0, rel=1e-6)
    value = rewards.velocity_reward(p, v, target, 0.8, 0.5)
    assert float(value) == pytest.approx(math.exp(-0.5 * 0.2**2), rel=1e-6)
    # the same speed as -d/dt |p - x_d| by a finite difference
    dt = 1e-7
    p64, target64, v64 = (np.asarray(a, dtype=float) for a in (p, target, v))
    before = np.linalg.norm(target64 - p64)
    after = np.linalg.norm(target64 - (p64 + v64 * dt))
    assert (before - after) / dt == pytest.approx(1.0, abs=1e-5)


def test_facing_reward_is_the_ground_plane_cosine() -> None:
    facing = jnp.array([1.0, 0.0, 0.3])  # a pitched robot still faces +x on the ground
    value = rewards.facing_reward(facing, jnp.zeros(3), jnp.array([1.0, 1.0, 5.0]))
    assert float(value) == pytest.approx(math.sqrt(0.5), rel=1e-5)
    behind = rewards.facing_reward(facing, jnp.zeros(3), jnp.array([-2.0, 0.0, 0.0]))
    assert float(behind) == pytest.approx(-1.0, rel=1e-5)


def test_thrust_penalty() -> None:
    value = rewards.thrust_penalty(jnp.array([125.0, 250.0, 0.0, 50.0]), 250.0)
    assert float(value) == pytest.approx(-(0.25 + 1.0 + 0.0 + 0.04), rel=1e-6)


def test_task_reward_uses_the_paper_weights() -> None:
    config = RewardConfig()
    assert (config.w_target, config.w_velocity, config.w_facing, config.w_thrust) == (
        0.1,
        0.7,
        0.2,
        0.11,
    )
    terms = rewards.task_terms(
        jnp.zeros(3),
        jnp.array([0.6, 0.8, 0.0]),
        jnp.array([1.0, 0.0, 0.0]),
        jnp.array([3.0, 4.0, 0.0]),
        jnp.array([125.0, 0.0, 0.0, 0.0]),
        250.0,
        config,
    )
    expected = (
        0.1 * math.exp(-0.5 * 25.0)
        + 0.7 * math.exp(-0.5 * (0.5 - 1.0) ** 2)
        + 0.2 * 0.6
        + 0.11 * -(0.5**2)
    )
    assert float(rewards.task_reward(terms, config)) == pytest.approx(expected, rel=1e-5)


def test_style_reward_is_scaled_minus_log_one_minus_sigmoid() -> None:
    logits = jnp.array([0.0, 2.0, -3.0, 40.0])
    value = np.asarray(rewards.style_reward(logits, 2.0))
    sigmoid = 1 / (1 + np.exp(-np.array([0.0, 2.0, -3.0])))
    np.testing.assert_allclose(value[:3], -2.0 * np.log(1 - sigmoid), rtol=1e-5)
    # 1 - sigmoid(40) is below the floor 1e-4: the reward is 2 * -log(1e-4) (and finite)
    assert value[3] == pytest.approx(2.0 * math.log(1e4), rel=1e-6)


def test_total_reward() -> None:
    assert float(rewards.total_reward(jnp.array(1.0), jnp.array(2.0), 0.5, 0.25)) == 1.0


def test_swing_reward_counts_a_foot_that_steps_while_another_is_down() -> None:
    down = jnp.array([False, True])
    # the left foot 4 cm up (half of 8 cm) moving at 0.25 m/s (half of v_d 0.5): 0.25;
    # the right foot is down and still: 0
    value = rewards.swing_reward(jnp.array([0.04, 0.0]), jnp.array([0.25, 0.0]), down, 0.08, 0.5)
    assert float(value) == pytest.approx(0.25, rel=1e-6)
    # higher and faster than the scales count as 1; both feet in the air count nothing (a hop)
    high = rewards.swing_reward(jnp.array([0.2, 0.0]), jnp.array([3.0, 0.0]), down, 0.08, 0.5)
    assert float(high) == pytest.approx(1.0, rel=1e-6)
    hop = rewards.swing_reward(
        jnp.array([0.2, 0.2]), jnp.array([3.0, 3.0]), jnp.array([False, False]), 0.08, 0.5
    )
    assert float(hop) == 0.0


def test_task_reward_adds_the_swing_term_by_its_weight() -> None:
    terms = {"target": 0.5, "velocity": 0.5, "facing": 0.5, "thrust": 0.0, "swing": 0.5}
    off, on = RewardConfig(), RewardConfig(w_swing=0.4)
    assert float(rewards.task_reward(terms, off)) == pytest.approx(0.5, rel=1e-6)
    assert float(rewards.task_reward(terms, on)) == pytest.approx(0.5 + 0.2, rel=1e-6)
