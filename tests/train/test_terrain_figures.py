"""The figures of a course, by hand: the mean level per kind (the curriculum's progress), route
successes, the airborne share over holes, the thrust per metre; and the evaluation per tile's
first-episode figures."""

import math

import jax.numpy as jnp
import numpy as np
import pytest

from motionkit.train.env import StepInfo
from motionkit.train.figures import rollout_figures
from motionkit.train.terrain_eval import TileRow, first_episode_figures, tile_table

T, N, HZ = 4, 3, 2.0  # 4 steps of 3 robots at 2 Hz


def arrays(**given: np.ndarray) -> dict[str, np.ndarray]:
    """Step records of T steps of N robots: all zero (False) but those `given`."""
    fields = {name: np.zeros((T, N), bool) for name in StepInfo.__dataclass_fields__}
    fields |= {"feet_down": np.ones((T, N, 2), bool), "terms": {}}
    for name in ("level", "kind", "moved", "approach_speed", "episode_reached"):
        fields[name] = np.zeros((T, N))
    return fields | given


def test_course_figures_by_hand() -> None:
    # robot 0 on a rough tile (kind 1) at level 3, robot 1 on a pits tile (kind 2) at level 5
    # then (from step 2, a new episode) level 6, robot 2 on pits at level 1. Robot 1 crosses
    # its moat airborne in steps 0-1 (over the hole in 1-2); each robot moves 0.5 m a step.
    done = np.array([[0, 0, 0], [0, 1, 0], [0, 0, 0], [1, 0, 1]], bool)
    level = np.array([[3, 5, 1], [3, 5, 1], [3, 6, 1], [3, 6, 1]])
    given = arrays(
        done=done,
        truncated=np.array([[0, 0, 0], [0, 1, 0], [0, 0, 0], [1, 0, 0]], bool),  # 2 fell
        level=level,
        kind=np.array([[1, 2, 2]] * T),
        airborne=np.array([[0, 1, 0], [0, 1, 0], [0, 0, 0], [0, 0, 0]], bool),
        over_hole=np.array([[0, 0, 0], [0, 1, 0], [0, 1, 0], [0, 0, 0]], bool),
        route_done=np.array([[0, 0, 0], [0, 1, 0], [0, 0, 0], [1, 0, 1]], bool),
        moved=np.full((T, N), 0.5),
    )
    info = StepInfo(**{k: jnp.asarray(v) for k, v in given.items() if k != "terms"}, terms={})
    thrust = np.zeros((T, N, 2))
    thrust[:2, 1] = 60.0  # robot 1's two jets push 60 N each for 2 steps of 0.5 s: 120 N s
    figures = rollout_figures(info, thrust, jnp.full(2, 100.0), HZ, ("flat", "rough", "pits"))
    figures = {k: float(v) for k, v in figures.items()}
    assert math.isnan(figures["terrain_level_flat"])  # no robot on a flat tile
    assert figures["terrain_level_rough"] == 3.0
    assert figures["terrain_level_pits"] == pytest.approx((5 + 5 + 6 + 6 + 4 * 1) / 8)
    # 3 episodes ended: robot 0's and 1's routes done, robot 2's done but it fell
    assert figures["route_success_share"] == pytest.approx(2 / 3)
    assert figures["airborne_share_over_hole"] == pytest.approx(1 / 2)
    assert figures["thrust_per_metre"] == pytest.approx(4 * 60.0 * 0.5 / (12 * 0.5))
    evaluation = rollout_figures(info, thrust, jnp.full(2, 100.0), HZ, ("a",), levels=False)
    assert "terrain_level_a" not in evaluation and "route_success_share" in evaluation
    flat = rollout_figures(info, thrust, jnp.full(2, 100.0), HZ)
    assert not {"route_success_share", "terrain_level_rough"} & set(flat)  # flat: as before


def test_first_episode_figures_by_hand() -> None:
    """Robot 0 walks its route (3 hits) and is cut off at the time limit; robot 1 flies over a
    hole (airborne 2 of its 3 steps, 2 of them over the hole) and falls at step 2; robot 2 has
    not ended. Steps after a robot's first end do not count."""
    hit = np.zeros((T, N), bool)
    hit[[0, 1, 2], 0] = True
    hit[3, 1] = True  # robot 1's next episode: not counted
    done = np.array([[0, 0, 0], [0, 0, 0], [0, 1, 0], [1, 0, 0]], bool)
    thrust = np.zeros((T, N, 4))
    thrust[:, 1] = 50.0  # robot 1: 200 N in each step; its ending step's is the next episode's
    given = arrays(
        hit=hit,
        done=done,
        truncated=np.array([[0, 0, 0], [0, 0, 0], [0, 0, 0], [1, 0, 0]], bool),
        route_done=np.array([[0, 0, 0], [0, 0, 0], [1, 1, 0], [1, 0, 0]], bool),
        airborne=np.array([[0, 1, 0], [0, 1, 0], [0, 0, 0], [0, 1, 0]], bool),
        over_hole=np.array([[0, 1, 0], [0, 1, 0], [0, 0, 0], [0, 1, 0]], bool),
        moved=np.full((T, N), 0.25),
        approach_speed=np.array([[0.5, 1.0, 0.0]] * T),
        thrust=thrust,
    )
    figures = first_episode_figures(given, HZ)
    assert figures["waypoints_per_episode"] == pytest.approx(3 / 3)
    assert figures["success_share"] == pytest.approx(1 / 3)  # robot 1 fell after its route
    assert figures["falls_per_episode"] == pytest.approx(1 / 3)
    assert figures["airborne_share"] == pytest.approx(2 / (4 + 3 + 4))
    assert figures["airborne_share_over_hole"] == 1.0
    # 2 steps x 200 N x 0.5 s over (4 + 3 + 4) steps x 0.25 m
    assert figures["thrust_per_metre"] == pytest.approx(200.0 / 2.75)
    assert figures["speed"] == pytest.approx((4 * 0.5 + 3 * 1.0) / 11)
    row = TileRow("pits", 9, 3, **figures)
    table = tile_table([row]).splitlines()
    assert len(table) == 3 and table[2].startswith("| pits | 9 | 1 | 0.333 | 0.333 |")
