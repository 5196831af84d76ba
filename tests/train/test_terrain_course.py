"""Courses, their routes and the curriculum of levels, against hand-worked cases: a robot at a
pit's edge sees the pit in the cells in front of it, routes over a pit cross it and wait on
its far side, ground waypoints on a stones tile stand on stones, the level moves up after a
route reached and down after a fall (into a pit too), and past the top to a random level."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from motionkit.core.errors import TrainError
from motionkit.train.config import EnvConfig
from motionkit.train.env import courses, levels, routes, terrain, tiles

KINDS = ("flat", "stones", "pits")
LAYOUT = courses.CourseLayout(3, KINDS, 8.0, seed=5)  # levels 0, 1, 2: d = 0, 0.5, 1


def test_tile_shapes_by_difficulty_against_hand_values() -> None:
    shapes = (tiles.pit_width, tiles.pit_depth, tiles.stone_gap, tiles.stone_side)
    ends = [[shape(0.0), shape(1.0)] for shape in (*shapes, tiles.bump_height)]
    np.testing.assert_allclose(ends, [[0.3, 1.5], [0.2, 1.0], [0.1, 0.8], [0.5, 0.3], [0.02, 0.12]])
    # stones at d = 1: side 0.3, gap 0.8 -> the first stone from 1.4 to 1.7 m, the next 2.5-2.8
    solid, index = tiles.stone_axis(np.array([0.3, 0.9, 1.5, 1.9, 2.6, -1.5]), 1.0)
    assert solid.tolist() == [True, False, True, False, True, True]
    assert index[[0, 2, 4, 5]].tolist() == [0, 1, 2, -1]
    snapped = tiles.snap_to_stone(np.array([0.2, 0.55, 1.2, 2.2, -2.0]), 1.0)
    np.testing.assert_allclose(snapped, [0.2, 1.55, 1.55, 2.65, -1.55])


def test_parse_tile_and_held_out_courses() -> None:
    assert courses.parse_tile("pits", LAYOUT) == (2, 2)  # no level: the hardest
    assert courses.parse_tile("stones:1", LAYOUT) == (1, 1)
    for bad in ("lava", "rough", "pits:3", "pits:x"):
        with pytest.raises(TrainError, match="--terrain"):
            courses.parse_tile(bad, LAYOUT)
    other = courses.held_out(LAYOUT, 2)
    assert other.seed == courses.HELD_OUT + 2 and other.kinds == LAYOUT.kinds
    assert not np.array_equal(courses.build_heights(other), courses.build_heights(LAYOUT))


def test_terrain_keys_are_checked() -> None:
    with pytest.raises(TrainError, match="terrain_kinds"):
        EnvConfig(terrain_kinds=("flat", "lava"))
    with pytest.raises(TrainError, match="terrain_kinds"):
        EnvConfig(terrain_kinds=("flat", "flat"))
    with pytest.raises(TrainError, match="tile_size"):
        EnvConfig(tile_size=3.0)
    with pytest.raises(TrainError, match="terrain_levels"):
        EnvConfig(terrain_levels=0)


def test_a_robot_at_a_pits_edge_sees_the_pit_in_front_of_it(robot) -> None:
    """The hardest pit tile (moat from 1.0 to 2.5 m about the centre, 1 m deep). A robot
    standing at (-0.65, 0.05) from the tile's centre faces -x (its forward axis, at the
    identity orientation): the map's rows 5 and 6 (0.6 and 0.9 m ahead, at x = -1.25 and -1.55)
    lie in the moat, rows 0-4 (x = 0.25 ... -0.95) on the ground inside it but for their
    outer columns (y = 1.25 and -1.15, in the moat's sides). Facing +y from (0.05, 0.65), the
    same map, turned."""
    from motionkit.train.env import Env
    from motionkit.train.env.mujoco import BatchPhysics

    layout = courses.CourseLayout(2, ("pits",), 8.0, seed=0)
    config = EnvConfig(scenario="terrain", terrain_levels=2, terrain_kinds=("pits",), impl="mujoco")
    env = Env(robot, config)
    physics = BatchPhysics(env, 2, threads=1)
    cx, cy = courses.tile_centre(layout, 1, 0)
    stand = np.asarray(env.stand_qpos, float)
    facing_y = np.array([np.cos(-np.pi / 4), 0, 0, np.sin(-np.pi / 4)])  # -x turned to +y
    qpos = np.stack([stand, stand])
    qpos[0, :3] = cx - 0.65, cy + 0.05, stand[2]
    qpos[1, :3], qpos[1, 3:7] = (cx + 0.05, cy + 0.65, stand[2]), facing_y
    data = physics.place(np.arange(2), qpos, np.zeros((2, env.mj_model.nv)))
    obs = jax.vmap(env.observe)(data, jnp.zeros((2, 4)), jnp.asarray(qpos[:, :3], jnp.float32))
    maps = np.asarray(obs[:, -66:-3]).reshape(2, 7, 9) + stand[2]  # heights about the datum
    inside = [-1.0, 0, 0, 0, 0, 0, 0, 0, -1.0]
    expected = np.array([inside] * 5 + [[-1.0] * 9] * 2)
    np.testing.assert_allclose(maps[0], expected, atol=1e-5)
    np.testing.assert_allclose(maps[1], expected[:, ::-1], atol=1e-5)  # y across -> -x


def test_routes_over_a_pit_cross_it_and_wait_on_the_far_side() -> None:
    """Routes of 3 ground waypoints from the middle of the hardest pit tile (moat from 1.0 to
    2.5 m about the centre, max-norm): every waypoint stands on solid ground, inside the moat
    or beyond it with its footprint (FOOTPRINT about it); every route crosses the moat (a leg
    passes over it). Turned back at the tile's edge, a route crosses it again."""
    ground = courses.build(LAYOUT)
    config = EnvConfig(waypoint_distance=(0.7, 2.0))
    centre = jnp.array(courses.tile_centre(LAYOUT, 2, 2), jnp.float32)
    draw = jax.jit(
        jax.vmap(
            lambda k, p: routes.course_waypoint(
                k, p, centre, jnp.array(1.0), jnp.array(False), config, ground, 3.0, 0.0
            )
        )
    )

    def route(start: jax.Array, seed: int) -> np.ndarray:
        points, previous = [np.tile(np.asarray(start), (300, 1))], jnp.tile(start, (300, 1))
        for key in jax.random.split(jax.random.key(seed), 3):
            previous = draw(jax.random.split(key, 300), previous)
            points.append(np.asarray(previous))
        return np.stack(points, axis=1)  # (routes, 4, 3): the start, then 3 waypoints

    def crossings(points: np.ndarray) -> np.ndarray:
        """Per route, the legs that pass over the moat."""
        t = np.linspace(0, 1, 60)[None, None, :, None]
        way = points[:, :-1, None, :2] + t * (points[:, 1:, None, :2] - points[:, :-1, None, :2])
        return np.asarray(terrain.over_hole(ground, jnp.asarray(way))).any(axis=2)

    points = route(jnp.array([centre[0], centre[1], 0.6]), 0)
    ring = np.abs(points[:, 1:, :2] - np.asarray(centre)).max(axis=2)
    assert ((ring <= 1.0) | (ring >= 2.5 + routes.FOOTPRINT)).all()
    assert not np.asarray(terrain.over_hole(ground, jnp.asarray(points[:, 1:, :2]))).any()
    np.testing.assert_allclose(points[:, 1:, 2], 0.6, atol=1e-5)  # standing on the datum
    assert crossings(points).any(axis=1).all()  # every route crosses the moat
    assert (ring >= 2.5).any(axis=1).all()  # and waits on its far side
    # from beyond the moat at the tile's edge: back over the moat toward the middle
    back = route(jnp.array([centre[0] + 3.0, centre[1], 0.6]), 1)
    assert crossings(back)[:, 0].mean() > 0.5 and crossings(back).any(axis=1).all()


def test_ground_waypoints_on_stones_stand_on_stones() -> None:
    ground = courses.build(LAYOUT)
    config = EnvConfig()
    centre = jnp.array(courses.tile_centre(LAYOUT, 2, 1), jnp.float32)
    previous = jnp.array([centre[0], centre[1], 0.6])
    draw = jax.vmap(
        lambda k: routes.course_waypoint(
            k, previous, centre, jnp.array(1.0), jnp.array(True), config, ground, 3.0, 0.0
        )
    )
    points = np.asarray(draw(jax.random.split(jax.random.key(1), 300)))
    around = points[:, None, :2] + np.array([[0, 0], [0.1, 0], [-0.1, 0], [0, 0.1], [0, -0.1]])
    heights = np.asarray(terrain.height_at(ground, jnp.asarray(around)))
    assert heights.min() > -0.06  # stone tops are within 5 cm of the datum; gaps are 1 m deep
    stones = np.abs(points[:, :2] - np.asarray(centre)).max(axis=1) > tiles.PAD
    assert stones.mean() > 0.8
    np.testing.assert_allclose(points[:, 2] - heights[:, 0], 0.6, atol=1e-5)


def test_the_level_moves_up_after_a_route_down_after_a_fall_and_past_the_top_at_random() -> None:
    tile = levels.Tile(
        jnp.array([1, 1, 0, 2, 1]), jnp.zeros(5, int), jnp.array([True] * 4 + [False])
    )
    up = jnp.array([True, False, False, True, True])
    down = jnp.array([False, True, True, False, False])
    keys = jax.random.split(jax.random.key(0), 5)
    step = jax.vmap(levels.next_tile, in_axes=(0, 0, 0, 0, None))
    moved = np.asarray(step(keys, tile, up, down, 3).level)
    assert moved[:3].tolist() == [2, 0, 0]  # up, down, and no lower than 0
    assert moved[4] == 1  # a tile held still (an evaluation's) stays
    # up from the top level: a random level, each about as often
    keys = jax.random.split(jax.random.key(1), 3000)
    top = levels.Tile(jnp.full(3000, 2), jnp.zeros(3000, int), jnp.ones(3000, bool))
    drawn = np.asarray(step(keys, top, jnp.ones(3000, bool), jnp.zeros(3000, bool), 3).level)
    np.testing.assert_allclose(np.bincount(drawn, minlength=3) / 3000, [1 / 3] * 3, atol=0.04)
    one = levels.Tile(jnp.array([2]), jnp.array([0]), jnp.array([True]))
    both = step(keys[:1], one, jnp.array([True]), jnp.array([True]), 3)
    assert int(both.level[0]) == 1  # a fall wins over a route reached
    # first tiles: levels 0 to max_start_level, held still without the curriculum
    first = jax.vmap(lambda k: levels.first_tile(k, 3, 1))(keys)
    assert set(np.asarray(first.level).tolist()) == {0, 1} and np.asarray(first.moves).all()
    assert not bool(levels.first_tile(keys[0], 3, 1, moves=False).moves)


def test_the_environment_moves_levels_at_the_end_of_episodes(robot) -> None:
    """Four robots of the MuJoCo backend on a 3-level course, each at the end of an episode:
    0 reached its route on level 1 (up to 2), 1 fell on level 1 (its base put 0.3 m up: down
    to 0), 2 reached its route on the top level (a random level), 3 stands in a level-1 pit,
    its base 0.6 m above the pit's floor and 0.15 m above the rim's datum: a fall (to 0)."""
    from motionkit.train.env import Env
    from motionkit.train.env.mujoco import BatchPhysics

    config = EnvConfig(
        scenario="terrain", terrain_levels=3, terrain_kinds=KINDS, impl="mujoco",
        terrain_seed=5, episode_seconds=1.0,
    )  # fmt: skip
    env = Env(robot, config)
    physics = BatchPhysics(env, 4, threads=1)
    tile = levels.Tile(jnp.array([1, 1, 2, 1]), jnp.array([0, 1, 0, 2]), jnp.ones(4, bool))
    state = physics.reset(jax.random.split(jax.random.key(3), 4), 0.0, 0.0, tile)
    np.testing.assert_array_equal(state.tile.level, [1, 1, 2, 1])
    centre = np.asarray(jax.vmap(env.tile_centre)(state.tile))
    np.testing.assert_allclose(state.data.qpos[:, :2], centre, atol=1e-6)
    qpos = np.asarray(physics.fields["qpos"]).copy()
    qpos[1, 2] = 0.3
    ring = 1.0 + tiles.pit_width(0.5) / 2  # the middle of the level-1 moat: 0.45 m deep
    qpos[3, :3] = centre[3, 0] + ring, centre[3, 1], -tiles.pit_depth(0.5) + 0.6
    data = physics.place(np.arange(4), qpos, np.zeros((4, env.mj_model.nv)))
    route = config.route_waypoints
    state = state.replace(
        data=data,
        reached=jnp.array([route, 0, route, 0], jnp.int32),
        steps=jnp.full(4, config.max_steps - 1, jnp.int32),
    )
    control = jax.jit(jax.vmap(env.control))
    ctrl, jet, thrust = control(state, jnp.tile(env.rest_action, (4, 1)))
    stepped, info, pose = jax.jit(jax.vmap(env.advance))(state, physics.step(ctrl), jet, thrust)
    assert np.asarray(info.done).all()
    assert np.asarray(info.truncated).tolist() == [True, False, True, False]  # 1, 3 fell
    assert bool(info.over_hole[3]) and not bool(info.over_hole[0])
    assert bool(info.route_done[0]) and not bool(info.route_done[1])
    next_levels = np.asarray(pose.tile.level)
    assert next_levels[[0, 1, 3]].tolist() == [2, 0, 0] and 0 <= next_levels[2] < 3
    np.testing.assert_array_equal(pose.tile.kind, [0, 1, 0, 2])  # an environment keeps its kind
    restarted = physics.restart(stepped, pose, np.asarray(info.done))
    np.testing.assert_array_equal(restarted.tile.level, next_levels)
    np.testing.assert_allclose(
        restarted.data.qpos[:, :2], np.asarray(jax.vmap(env.tile_centre)(pose.tile)), atol=1e-6
    )


def test_a_clip_records_the_terrain_under_its_path() -> None:
    """The grid's points from low to high (x, y), widened to whole cells: the hard pit tile
    of the 24 x 24 m course (kind 2, level 2, centred at (8, 8))."""
    box = courses.clip_terrain(LAYOUT, 2, 2, np.array([7.05, 6.05]), np.array([9.05, 7.05]))
    heights = courses.build_heights(LAYOUT)
    assert box["kind"] == "pits" and box["level"] == 2 and box["cell"] == terrain.CELL
    assert courses.CourseLayout.from_dict(box["course"]) == LAYOUT
    np.testing.assert_allclose(box["origin"], [7.0, 6.0], atol=1e-9)
    part = np.array(box["heights"])
    assert part.shape == (12, 22)  # y 6.0-7.1, x 7.0-9.1 at 0.1 m
    np.testing.assert_allclose(part, heights[180:192, 190:212], atol=1e-4)
    assert part.min() == -1.0  # the moat from 1.0 to 2.5 m about x = 8
