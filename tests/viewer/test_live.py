"""The live rollout view of `motionkit play --view` without a browser: where a click places a
waypoint, the click handler, and the watcher that poses the robot and hands over placed
waypoints."""

from collections.abc import Iterator
from types import SimpleNamespace

import numpy as np
import pytest
from viewer_support import free_port

pytest.importorskip("viser")

from motionkit.robot import ironcub
from motionkit.viewer.live import CURRENT_COLOR, DONE_COLOR, LiveView, floor_waypoint


def test_floor_waypoint() -> None:
    # from 2 m up, looking 45 degrees down along +x: the floor 2 m ahead
    point = floor_waypoint((0.0, 0.0, 2.0), (1.0, 0.0, -1.0), 0.6)
    np.testing.assert_allclose(point, [2.0, 0.0, 0.6])
    np.testing.assert_allclose(floor_waypoint((1, 2, 3), (0, 0, -5), 1.2), [1, 2, 1.2])
    assert floor_waypoint((0, 0, 2), (1, 0, 0), 0.6) is None  # level: never meets the floor
    assert floor_waypoint((0, 0, 2), (0, 0.5, 1), 0.6) is None  # looking up
    assert floor_waypoint((0, 0, -1), (0, 0, -1), 0.6) is None  # below the floor
    assert floor_waypoint((0, 0, np.nan), (0, 0, -1), 0.6) is None


@pytest.fixture(scope="module")
def view() -> Iterator[LiveView]:
    live = LiveView(ironcub(), [np.array([1.0, 0.0, 0.6])], height=0.6, port=free_port())
    yield live
    live.close()


def test_a_click_places_the_next_waypoint_at_the_slider_height(view: LiveView) -> None:
    view.height.value = 1.2
    view._clicked(SimpleNamespace(ray_origin=(0.0, 0.0, 3.0), ray_direction=(0.0, 1.0, -1.0)))
    assert view._clicked(SimpleNamespace(ray_origin=(0, 0, 3), ray_direction=(0, 0, 1))) is None
    np.testing.assert_allclose(view.route[-1], [0.0, 3.0, 1.2])
    np.testing.assert_allclose(view._points.points, [[1, 0, 0.6], [0, 3, 1.2]])

    robot = view.scene.robot
    qpos = np.concatenate([[0.5, 0.0, 0.7, 1.0, 0.0, 0.0, 0.0], np.zeros(len(robot.joint_names))])
    placed = view.watch(qpos, np.full(4, 125.0), np.array([True, False]), view.route[0])
    np.testing.assert_allclose(placed, [[0.0, 3.0, 1.2]])  # handed over once
    assert view.watch(qpos, np.zeros(4), np.array([True, True]), view.route[0]) == []
    np.testing.assert_allclose(
        view.scene.poses[view.scene.poser.index["root_link"]][:3, 3], qpos[:3]
    )
    assert "pursuing (1.00, 0.00, 0.60) m" in view.status.content
    view.watch(qpos, np.zeros(4), np.array([True, True]), view.route[1])  # the next one
    assert view.current == 1
    assert (view._points.colors[0] == DONE_COLOR).all()
    assert (view._points.colors[1] == CURRENT_COLOR).all()
