"""A rollout shown live (`motionkit play --view`): the robot as it is stepped, its waypoints,
and a click on the floor placing the next waypoint at the height the slider sets.

    view = LiveView(robot, route, height=0.6)   # served on 127.0.0.1 at view.url
    roll_out(..., watch=view.watch)             # poses the robot, hands over placed waypoints

`floor_waypoint` is the placing rule on its own (no server).
"""

from __future__ import annotations

import threading
from collections.abc import Sequence

import numpy as np
import viser

from motionkit.core.errors import ViewerError
from motionkit.robot import Robot
from motionkit.robot.geometry import Array
from motionkit.viewer.app import CAMERA_FOV, CAMERA_OFFSET, HOST
from motionkit.viewer.meshes import LinkMesh, robot_meshes
from motionkit.viewer.scene import FrameState, RobotScene

HEIGHT_RANGE = (0.3, 2.5)  # m, of the waypoint height slider
DONE_COLOR = (150, 150, 150)
WAYPOINT_COLOR = (30, 110, 240)
CURRENT_COLOR = (240, 60, 30)


def floor_waypoint(
    origin: Sequence[float], direction: Sequence[float], height: float
) -> Array | None:
    """The waypoint a click places: where its ray (origin, direction) meets the floor (z = 0),
    raised to `height` [m]; None when the ray does not come down to the floor in front of it."""
    o, d = np.asarray(origin, float), np.asarray(direction, float)
    if not (np.isfinite(o).all() and np.isfinite(d).all()) or d[2] >= -1e-9 or o[2] < 0:
        return None
    point = o - o[2] / d[2] * d
    return np.array([point[0], point[1], float(height)])


class LiveView:
    """A viser server showing a rollout; `watch` is `motionkit.train.play.roll_out`'s hook."""

    def __init__(
        self,
        robot: Robot,
        route: Sequence[Array],
        *,
        height: float,
        start: Sequence[float] = (0.0, 0.0, 0.0),
        port: int = 8080,
        meshes: list[LinkMesh] | None = None,
    ) -> None:
        if meshes is None:
            meshes, _ = robot_meshes(robot)
        try:
            self.server = viser.ViserServer(host=HOST, port=port, verbose=False)
        except OSError as exc:
            raise ViewerError(f"cannot serve on {HOST}:{port} ({exc.strerror or exc})") from exc
        self._lock = threading.Lock()
        self.route = [np.asarray(p, float) for p in route]
        self.pending: list[Array] = []  # placed, not yet handed to the rollout
        self.current = 0  # index in route of the waypoint pursued
        server = self.server
        server.scene.set_up_direction("+z")
        server.initial_camera.fov = CAMERA_FOV
        server.scene.add_grid("/floor", 20.0, 20.0, cell_size=0.5, section_size=1.0)
        self.scene = RobotScene(server, robot, meshes)
        gui = server.gui
        gui.add_markdown("Click on the floor to place the next waypoint at this height.")
        low, high = HEIGHT_RANGE
        initial = min(max(height, low), high)
        self.height = gui.add_slider("waypoint height [m]", low, high, 0.05, initial)
        self.status = gui.add_markdown("")
        self._points = server.scene.add_point_cloud(
            "/overlays/waypoints", np.zeros((1, 3), np.float32), WAYPOINT_COLOR,
            point_size=0.08, point_shape="circle", precision="float32",
        )  # fmt: skip
        look_at = np.asarray(start, float) * [1, 1, 0.5]
        server.initial_camera.look_at = tuple(look_at)
        server.initial_camera.position = tuple(look_at + CAMERA_OFFSET)
        self._draw()
        server.scene.on_click()(self._clicked)

    @property
    def url(self) -> str:
        return f"http://{HOST}:{self.server.get_port()}"

    def place(self, origin: Sequence[float], direction: Sequence[float]) -> Array | None:
        """Place the next waypoint where a click's ray meets the floor (None: it does not)."""
        point = floor_waypoint(origin, direction, self.height.value)
        if point is not None:
            with self._lock:
                self.pending.append(point)
                self.route.append(point)
            self._draw()
        return point

    def _clicked(self, event: viser.SceneClickEvent) -> None:
        self.place(event.ray_origin, event.ray_direction)

    def watch(self, qpos: Array, thrust: Array, feet_down: Array, target: Array) -> list[Array]:
        """Show one control step's state; the waypoints placed since the last call."""
        quat = qpos[3:7] / np.linalg.norm(qpos[3:7])
        self.scene.show(FrameState(qpos[:3], quat, qpos[7:], thrust, feet_down))
        with self._lock:
            placed, self.pending = self.pending, []
            later = range(self.current, len(self.route))
            index = next((k for k in later if np.array_equal(self.route[k], target)), None)
        if index is not None and index != self.current:
            self.current = index
            self._draw()
        x, y, z = target
        self.status.content = f"pursuing ({x:.2f}, {y:.2f}, {z:.2f}) m"
        return placed

    def _draw(self) -> None:
        with self._lock:
            points = np.array(self.route, np.float32).reshape(-1, 3)
            current = self.current
        colors = np.tile(np.array(WAYPOINT_COLOR, np.uint8), (len(points), 1))
        colors[:current] = DONE_COLOR
        colors[current : current + 1] = CURRENT_COLOR
        self._points.points, self._points.colors = points, colors

    def close(self) -> None:
        self.server.stop()
