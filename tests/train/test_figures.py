"""The rollout figures of hand-made step records: gait, flight and per-episode counts."""

import jax.numpy as jnp
import numpy as np
import pytest

from motionkit.train.env import StepInfo
from motionkit.train.figures import rollout_figures

T, N, HZ = 4, 2, 2.0  # 4 steps of 2 robots at 2 Hz: 1 s is 2 steps


def records(**given: np.ndarray) -> StepInfo:
    """Step records of T steps of N robots: all False but those `given`, both soles down."""
    fields = {name: np.zeros((T, N), bool) for name in StepInfo.__dataclass_fields__}
    fields |= {"feet_down": np.ones((T, N, 2), bool)} | given
    return StepInfo(**{k: jnp.asarray(v) for k, v in fields.items() if k != "terms"}, terms={})


def test_flight_figures_by_hand() -> None:
    # robot 0 pursues a ground waypoint, then (from step 2) an air one, airborne in steps 1-3;
    # robot 1 stays on the ground pursuing ground waypoints. Both episodes end at step 3.
    airborne = np.array([[0, 0], [1, 0], [1, 0], [1, 0]], bool)
    air_target = np.array([[0, 0], [0, 0], [1, 0], [1, 0]], bool)
    done = np.array([[0, 0], [0, 0], [0, 0], [1, 1]], bool)
    info = records(
        airborne=airborne,
        air_target=air_target,
        done=done,
        truncated=done,
        episode_steps=np.array([[1, 1], [2, 2], [3, 3], [4, 4]]),
        episode_reached=np.array([[0, 0], [1, 0], [1, 1], [2, 1]]),
        episode_air_reached=np.array([[0, 0], [0, 0], [0, 0], [1, 0]]),
        episode_longest_flight=np.array([[0, 0], [1, 0], [2, 0], [3, 0]]),
    )
    thrust = np.zeros((T, N, 2))
    thrust[1:, 0] = [30.0, 50.0]  # robot 0 airborne at a mean 40 % of T_max = 100 N
    figures = {
        k: float(v) for k, v in rollout_figures(info, thrust, jnp.full(2, 100.0), HZ).items()
    }
    assert figures["airborne_share"] == pytest.approx(3 / 8)
    assert figures["airborne_share_to_ground"] == pytest.approx(1 / 6)  # 1 of 6 ground steps
    assert figures["airborne_share_to_air"] == pytest.approx(1.0)
    assert figures["thrust_usage"] == pytest.approx(3 * 0.4 / 8)
    assert figures["thrust_usage_airborne"] == pytest.approx(0.4)
    assert figures["episodes"] == 2
    assert figures["waypoints_per_episode"] == pytest.approx(1.5)
    assert figures["air_waypoints_per_episode"] == pytest.approx(0.5)
    assert figures["flight_1s_share"] == pytest.approx(0.5)  # robot 0: 3 steps = 1.5 s
    assert figures["falls"] == 0


def test_without_air_waypoints_their_share_is_nan() -> None:
    info = records(done=np.zeros((T, N), bool))
    figures = rollout_figures(info, np.zeros((T, N, 2)), jnp.full(2, 100.0), HZ)
    assert np.isnan(float(figures["airborne_share_to_air"]))
    assert float(figures["airborne_share_to_ground"]) == 0.0
    assert np.isnan(float(figures["thrust_usage_airborne"]))
