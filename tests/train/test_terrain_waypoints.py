"""Terrain heights (bilinear sampling agrees with MuJoCo's heightfield) and waypoint routes."""

import dataclasses

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from motionkit.core.errors import TrainError
from motionkit.train.config import EnvConfig
from motionkit.train.env import courses, terrain, waypoints


def test_height_at_is_bilinear_with_rows_along_y() -> None:
    grid = terrain.Terrain(jnp.array([[0.0, 1.0], [2.0, 3.0]]), cell=1.0)
    points = jnp.array([[0.0, 0.0], [-0.5, -0.5], [0.5, -0.5], [-0.5, 0.5], [0.25, 0.0], [9, 9]])
    np.testing.assert_allclose(
        np.asarray(terrain.height_at(grid, points)), [1.5, 0.0, 1.0, 2.0, 1.75, 3.0], atol=1e-6
    )


def test_a_course_has_a_row_per_level_a_column_per_kind_and_flat_pads() -> None:
    """The tiled course (which replaced the 4 x 4 mix of 4 m tiles): 2 levels x 4 kinds of 8 m
    tiles, 0.1 m cells; every tile's pad is flat at the datum, and the hard row is harder."""
    layout = courses.CourseLayout(2, ("flat", "rough", "stones", "pits"), 8.0, seed=0)
    ground = courses.build(layout)
    heights = np.asarray(ground.heights)
    assert heights.shape == (161, 321) and ground.datum == 0.0
    centres = np.array([courses.tile_centre(layout, lv, k) for lv in (0, 1) for k in range(4)])
    np.testing.assert_allclose(centres[:4], [[-12, -4], [-4, -4], [4, -4], [12, -4]])
    offsets = np.array([[0.0, 0.0], [0.5, 0.5], [-0.5, 0.3]])
    around = (centres[:, None, :] + offsets[None]).reshape(-1, 2)
    np.testing.assert_array_equal(np.asarray(terrain.height_at(ground, jnp.asarray(around))), 0)

    def tile(level: int, kind: int) -> np.ndarray:
        column, row = (
            round((centres[4 * level + kind, 0] + 16) / 0.1),
            round((centres[4 * level + kind, 1] + 8) / 0.1),
        )
        return heights[row - 39 : row + 40, column - 39 : column + 40]

    assert np.all(tile(0, 0) == 0) and np.all(tile(1, 0) == 0)  # flat
    assert 0 < tile(0, 1).max() <= 0.02 and 0.1 < tile(1, 1).max() <= 0.12  # bumps: 2 -> 12 cm
    assert tile(0, 1).min() >= 0  # bumps rise from the datum
    assert tile(0, 3).min() == pytest.approx(-0.2) and tile(1, 3).min() == pytest.approx(-1.0)
    assert tile(1, 2).min() == -1.0  # the gaps between stones
    gaps = [np.mean(tile(level, 2) < -0.5) for level in (0, 1)]
    assert gaps[0] < gaps[1]  # wider gaps at the top level


def test_heightfield_in_mujoco_matches_height_at(robot) -> None:
    mujoco = pytest.importorskip("mujoco")
    from motionkit.train.env import mjcf_text

    ground = courses.build(courses.CourseLayout(2, ("rough", "stones", "pits"), 8.0, seed=3))
    model = mujoco.MjModel.from_xml_string(mjcf_text(robot, ground))
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    rng = np.random.default_rng(0)
    points = rng.uniform([-11.5, -7.5], [11.5, 7.5], size=(400, 2))
    hit = np.zeros(1, np.int32)
    measured = []
    for x, y in points:
        distance = mujoco.mj_ray(
            model, data, np.array([x, y, 5.0]), np.array([0, 0, -1.0]), None, 1, -1, hit
        )
        measured.append(5.0 - distance)
    expected = np.asarray(terrain.height_at(ground, jnp.asarray(points)))
    # MuJoCo renders the grid as triangles; bilinear differs inside a cell only on slopes
    assert np.median(np.abs(np.array(measured) - expected)) < 1e-3
    assert np.mean(np.abs(np.array(measured) - expected) < 0.02) > 0.9


def test_waypoints_keep_their_spacing_and_heights() -> None:
    config = EnvConfig(air_probability=0.3)
    flat = terrain.flat()
    start = jnp.array([0.0, 0.0, config.ground_height])
    keys = jax.random.split(jax.random.key(0), 2000)
    sample = jax.jit(jax.vmap(lambda k: waypoints.next_waypoint(k, start, config, flat, 1e6, 0.3)))
    points = np.asarray(sample(keys))
    air = points[:, 2] > config.ground_height + 1e-6
    assert np.mean(air) == pytest.approx(0.3, abs=0.04)
    assert np.all((points[air, 2] >= 0.9) & (points[air, 2] <= 1.5))
    np.testing.assert_allclose(points[~air, 2], config.ground_height)
    distance = np.linalg.norm(points - np.asarray(start), axis=1)
    assert distance.min() >= 0.7 - 1e-5 and distance.max() <= 2.0 + 1e-5
    assert distance[air].min() >= 0.7 - 1e-5  # climbs count in the 3-D spacing


def test_waypoints_stay_inside_the_bound() -> None:
    config = dataclasses.replace(EnvConfig(), air_probability=0.0)
    start = jnp.array([4.9, -4.9, config.ground_height])
    keys = jax.random.split(jax.random.key(1), 200)
    points = jax.vmap(
        lambda k: waypoints.next_waypoint(k, start, config, terrain.flat(), 5.0, 0.0)
    )(keys)
    assert float(jnp.abs(points[:, :2]).max()) <= 5.0
    assert bool(waypoints.reached(jnp.zeros(3), jnp.array([0.2, 0.0, 0.1]), 0.3))
    assert not bool(waypoints.reached(jnp.zeros(3), jnp.array([0.3, 0.0, 0.1]), 0.3))


def test_waypoint_deadline_against_hand_values() -> None:
    config = EnvConfig()  # 1.5 x distance / v_desired + 2 s at 60 Hz
    start, target = jnp.zeros(3), jnp.array([0.9, 1.2, 0.0])  # 1.5 m away
    # 1.5 * 1.5 / 0.8 + 2 = 4.8125 s -> 288.75 -> 289 steps
    assert int(waypoints.deadline_steps(start, target, config, 0.8)) == 289
    # 1.5 * 1.5 / 0.5 + 2 = 6.5 s -> 390 steps
    assert int(waypoints.deadline_steps(start, target, config, 0.5)) == 390
    off = dataclasses.replace(config, waypoint_timeout=False)
    assert int(waypoints.deadline_steps(start, target, off, 0.5)) == 2**31 - 1


def test_air_waypoint_curriculum_against_hand_values() -> None:
    ramp = EnvConfig(air_probability=0.5, air_curriculum=200)
    shares = [float(waypoints.air_share(i, ramp)) for i in (0, 50, 100, 200, 1000)]
    np.testing.assert_allclose(shares, [0.0, 0.125, 0.25, 0.5, 0.5], rtol=1e-6)
    assert float(waypoints.air_share(7, EnvConfig(air_probability=0.3))) == pytest.approx(0.3)
    keys = jax.random.split(jax.random.key(4), 1000)
    start = jnp.array([0.0, 0.0, 0.6])
    sample = jax.vmap(lambda k: waypoints.next_waypoint(k, start, ramp, terrain.flat(), 1e6, 0.0))
    assert np.all(np.asarray(sample(keys))[:, 2] == pytest.approx(0.6))  # share 0: ground only


def test_waypoints_within_the_angle_of_the_facing() -> None:
    """waypoint_angle 45: every direction within 45 degrees of the heading (here 120 deg), and
    both edges of the cone reached; 180 keeps any direction."""
    cone = dataclasses.replace(EnvConfig(), air_probability=0.0, waypoint_angle=45.0)
    start = jnp.array([0.0, 0.0, cone.ground_height])
    keys = jax.random.split(jax.random.key(2), 2000)
    heading = np.deg2rad(120.0)
    points = np.asarray(
        jax.vmap(
            lambda k: waypoints.next_waypoint(k, start, cone, terrain.flat(), 1e6, 0.0, heading)
        )(keys)
    )
    off = np.rad2deg(np.arctan2(points[:, 1], points[:, 0])) - 120.0
    assert np.abs(off).max() <= 45.0 + 1e-3 and np.abs(off).max() > 44.0
    anywhere = jax.vmap(
        lambda k: waypoints.next_waypoint(k, start, EnvConfig(), terrain.flat(), 1e6, 0.0, heading)
    )(keys)
    directions = np.rad2deg(np.arctan2(anywhere[:, 1], anywhere[:, 0]))
    assert directions.min() < -170.0 and directions.max() > 170.0
    with pytest.raises(TrainError, match="waypoint_angle"):
        EnvConfig(waypoint_angle=0.0)
