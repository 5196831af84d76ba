"""`ViewerApp`: a viser server that plays clips, or shows the robot alone with joint sliders.

    app = ViewerApp(robot, resolve_clips("datasets/walk"), port=8080)
    app.set_time(2.5); app.current_pose()["l_foot"]; app.close()

Every clip's metadata, and the whole first clip, are checked before the server starts (a
ViewerError otherwise); the server binds to 127.0.0.1, on the next free port when `port` is taken
(`port_note`). A background thread advances the timeline with the wall clock (at the clip's rate,
at most MAX_TICK_RATE Hz), so that playback runs at real time whatever the frame cost.
"""

from __future__ import annotations

import threading
import time as clock
from collections.abc import Sequence

import numpy as np
import viser
import viser.uplot

from motionkit.core.errors import ViewerError
from motionkit.dataset import Trajectory, corner_names
from motionkit.robot import Robot
from motionkit.robot.geometry import Array
from motionkit.viewer.engines import EngineBars, engine_shares, lag_plot
from motionkit.viewer.meshes import LinkMesh, robot_meshes
from motionkit.viewer.playback import Playback
from motionkit.viewer.scene import FORCE_SCALE, FrameState, RobotScene
from motionkit.viewer.skeleton import SKELETON_OFFSET, SkeletonOverlay, side_offset
from motionkit.viewer.sources import (
    ClipInfo,
    check_robot,
    contact_forces,
    describe,
    literal,
    load_motion,
    waypoints,
)
from motionkit.viewer.terrain import TerrainPatch, clip_terrain, grid_mesh

HOST = "127.0.0.1"
MAX_TICK_RATE = 120.0  # Hz
SLIDER_RATE = 10.0  # Hz, timeline slider updates while playing
FOLLOW_RATE = 20.0  # Hz, camera updates while following the robot
PLOT_POINTS = 1500  # samples per plotted series
SPEEDS = ("0.1", "0.25", "0.5", "1", "2", "4")
CAMERA_OFFSET = np.array([2.0, -2.0, 0.6])  # m, from the base to the initial camera
CAMERA_FOV = np.radians(50.0)  # vertical field of view of the initial camera
TERRAIN_COLOR = (150, 146, 132)  # of a clip's terrain (a course's heights)


class ViewerApp:
    """The viewer of `clips` (newest first), or of the robot alone when `clips` is empty."""

    def __init__(
        self,
        robot: Robot,
        clips: Sequence[ClipInfo] = (),
        *,
        port: int = 8080,
        meshes: list[LinkMesh] | None = None,
        play: bool = False,
        verbose: bool = False,
        skeleton_offset: float = SKELETON_OFFSET,
    ) -> None:
        self.robot = robot
        self.skeleton_offset = skeleton_offset  # m, the human skeleton to the robot's left
        self.clips = list(clips)
        warnings = [check_robot(clip, robot) for clip in self.clips]  # raises on a misfit
        self.motion: Trajectory | None = load_motion(self.clips[0], robot) if self.clips else None
        if meshes is None:
            meshes, problems = robot_meshes(robot)
            warnings += [f"not drawn: {p}" for p in problems]
        self.warnings = warnings
        self._lock = threading.RLock()
        self._closed = threading.Event()
        try:
            self.server = viser.ViserServer(host=HOST, port=port, verbose=verbose)
        except OSError as exc:
            raise ViewerError(f"cannot serve on {HOST}:{port} ({exc.strerror or exc})") from exc
        self.requested_port = port
        self.server.scene.set_up_direction("+z")
        self.server.initial_camera.fov = CAMERA_FOV
        self.server.scene.add_grid("/floor", 20.0, 20.0, cell_size=0.5, section_size=1.0)
        self.scene = RobotScene(self.server, robot, meshes)
        self._clip_gui: list[viser.GuiInputHandle | viser.GuiMarkdownHandle] = []
        self._waypoints: list[viser.SceneNodeHandle] = []
        self._terrain: viser.SceneNodeHandle | None = None
        self.playback: Playback | None = None
        self.rate = 0.0  # Hz, of the clip shown
        self.forces: Array | None = None
        self.skeleton: SkeletonOverlay | None = None
        self.engines: EngineBars | None = None  # the clip's throttle and thrust per jet
        self.lag_plots: list[viser.GuiUplotHandle] = []
        self.t_max = np.array([jet.t_max for jet in robot.spec.jets], float)
        self._description = ""
        self.index = 0
        if self.motion is not None:
            self._build_player(play)
        else:
            self._build_robot_only()
        self._thread = threading.Thread(target=self._run, name="motionkit-viewer", daemon=True)
        self._thread.start()

    # -- public API ----------------------------------------------------------------------------
    @property
    def url(self) -> str:
        return f"http://{HOST}:{self.server.get_port()}"

    def port_note(self) -> str:
        """ "" when serving on the port asked for; otherwise which port it took instead."""
        port = self.server.get_port()
        if port == self.requested_port:
            return ""
        return f"port {self.requested_port} is in use; serving on port {port} instead"

    def set_time(self, t: float) -> int:
        """Show the clip at time t [s] (clamped); the frame index shown."""
        playback = self._player()
        with self._lock:
            frame = playback.seek(t)
            self._show(frame)
            self.slider.value = playback.now
        return frame

    def play(self, playing: bool = True) -> None:
        with self._lock:
            self._player().playing = playing
            self._tick_reference = clock.perf_counter()
            self.play_button.label = "Pause" if playing else "Play"

    def select_clip(self, index: int) -> None:
        """Show the clip `index` of `clips` from its start (its motion read now)."""
        with self._lock:
            motion = load_motion(self.clips[index], self.robot)
            self.index, self.motion = index, motion
            self.picker.value = self._clip_names()[index]
            self._set_clip(motion)

    def pick(self, name: str) -> None:
        """Show the clip labelled `name` in the picker, or say on the page why it cannot be."""
        try:
            self.select_clip(self._clip_names().index(name))
        except ViewerError as exc:  # a clip corrupted after the start: say so, keep on
            self.info.content = f"**cannot show {literal(name)}**: {literal(str(exc))}"

    def current_pose(self) -> dict[str, Array]:
        """World pose (4, 4) of every link as shown now."""
        with self._lock:
            return {link: self.scene.poses[i].copy() for link, i in self.scene.poser.index.items()}

    @property
    def frame(self) -> int:
        return self._player().frame

    def wait(self) -> None:
        """Block until close() (or Ctrl-C)."""
        while not self._closed.wait(0.5):
            pass

    def close(self) -> None:
        self._closed.set()
        self._thread.join(timeout=2.0)
        self.server.stop()

    # -- clips ---------------------------------------------------------------------------------
    def _player(self) -> Playback:
        if self.playback is None:
            raise ViewerError("no clip is shown (the viewer shows the robot alone)")
        return self.playback

    def _clip_names(self) -> list[str]:
        seen: dict[str, int] = {}
        names = []
        for clip in self.clips:  # unique labels for clips with the same file name
            seen[clip.name] = seen.get(clip.name, 0) + 1
            names.append(clip.name if seen[clip.name] == 1 else f"{clip.name} ({seen[clip.name]})")
        return names

    def _build_player(self, play: bool) -> None:
        gui = self.server.gui
        gui.configure_theme(control_width="large")
        with gui.add_folder("Clip"):
            self.picker = gui.add_dropdown("clip", self._clip_names(), visible=len(self.clips) > 1)
            self.info = gui.add_markdown("")
        with gui.add_folder("Playback"):
            self.slider = gui.add_slider("time [s]", 0.0, 1.0, 0.01, 0.0)
            self.play_button = gui.add_button("Play", icon=viser.Icon.PLAYER_PLAY)
            self.speed = gui.add_dropdown("speed", SPEEDS, initial_value="1")
            self.loop = gui.add_checkbox("loop", True)
            self.follow = gui.add_checkbox("follow robot", True)
        with gui.add_folder("Show"):
            self.show_robot = gui.add_checkbox("robot", True)
            self.show_waypoints = gui.add_checkbox("waypoints", True)
            self.show_terrain = gui.add_checkbox("terrain", True)
            self.show_skeleton = gui.add_checkbox("human skeleton", True)
            self.show_forces = gui.add_checkbox("contact forces", True)
        self.plots = gui.add_folder("Plots", expand_by_default=False)

        @self.picker.on_update
        def _(event: viser.GuiEvent) -> None:
            if event.client is not None:
                self.pick(self.picker.value)

        @self.slider.on_update
        def _(event: viser.GuiEvent) -> None:
            if event.client is not None:  # a person moved it (not the playback thread)
                with self._lock:
                    self._show(self._player().seek(self.slider.value))

        @self.play_button.on_click
        def _(_: viser.GuiEvent) -> None:
            self.play(not self._player().playing)

        @self.speed.on_update
        def _(_: viser.GuiEvent) -> None:
            self._player().speed = float(self.speed.value)

        @self.loop.on_update
        def _(_: viser.GuiEvent) -> None:
            self._player().loop = self.loop.value

        @self.show_robot.on_update
        def _(_: viser.GuiEvent) -> None:
            with self._lock:
                self.scene.set_visible(self.show_robot.value)
                self._show(self._player().frame)

        @self.show_waypoints.on_update
        def _(_: viser.GuiEvent) -> None:
            for handle in self._waypoints:
                handle.visible = self.show_waypoints.value

        @self.show_terrain.on_update
        def _(_: viser.GuiEvent) -> None:
            if self._terrain is not None:
                self._terrain.visible = self.show_terrain.value

        @self.show_skeleton.on_update
        def _(_: viser.GuiEvent) -> None:
            with self._lock:
                if self.skeleton is not None:
                    self.skeleton.visible = self.show_skeleton.value
                self._show(self._player().frame)
                self._describe_overlays()

        @self.show_forces.on_update
        def _(_: viser.GuiEvent) -> None:
            with self._lock:
                self.scene.show_forces = self.show_forces.value
                self._show(self._player().frame)
                self._describe_overlays()

        assert self.motion is not None
        self._set_clip(self.motion)
        position = self.motion.base_position[0].astype(float)
        self.server.initial_camera.look_at = tuple(position)
        self.server.initial_camera.position = tuple(position + CAMERA_OFFSET)
        if play:
            self.play(True)

    def _set_clip(self, motion: Trajectory) -> None:
        clip = self.clips[self.index]
        self.forces = contact_forces(motion, corner_names(self.robot))
        self.show_forces.disabled = self.forces is None
        self._set_skeleton(motion)
        self._set_engines(motion)
        self.playback = Playback(motion.time, float(self.speed.value), self.loop.value)
        self.rate = motion.rate
        step = 1.0 / self.rate if self.rate > 0 else 0.01
        self.slider.min, self.slider.max = float(motion.time[0]), float(motion.time[-1])
        self.slider.step = step
        self.slider.value = float(motion.time[0])
        notes = (self.warnings[self.index], *self.warnings[len(self.clips) :])
        warning = "; ".join(w for w in notes if w)
        self._description = describe(clip, warning)
        self._describe_overlays()
        self._draw_waypoints(waypoints(clip))
        self._draw_terrain(clip_terrain(clip))
        self._draw_plots(motion)
        self._show(0)

    def _set_skeleton(self, motion: Trajectory) -> None:
        """The clip's human skeleton beside the robot (none without landmarks)."""
        if self.skeleton is not None:
            self.skeleton.remove()
            self.skeleton = None
        self.show_skeleton.disabled = motion.landmarks is None
        if motion.landmarks is None:
            return
        offset = side_offset(
            self.robot.spec.forward, motion.base_orientation[0], self.skeleton_offset
        )
        self.skeleton = SkeletonOverlay(
            self.server, motion.landmark_parents, offset, self.show_skeleton.value
        )

    def _set_engines(self, motion: Trajectory) -> None:
        """Two bars per jet, throttle and thrust, for a clip with a throttle (none without)."""
        if self.engines is not None:
            self.engines.remove()
            self.engines = None
        if engine_shares(motion, self.t_max) is not None:
            self.engines = EngineBars(self.server.gui, motion.jet_names, self.t_max)

    def _describe_overlays(self) -> None:
        """The clip's description, and which of its skeleton and contact forces are shown."""
        motion = self.motion
        assert motion is not None
        lines = []
        if motion.landmarks is not None:
            state = "shown" if self.show_skeleton.value else "hidden"
            lines.append(
                f"human skeleton ({len(motion.landmark_names)} landmarks, scaled to the robot) "
                f"{state}, {self.skeleton_offset:g} m to the robot's left"
            )
        if self.forces is not None:
            state = "shown" if self.show_forces.value else "hidden"
            lines.append(
                f"planned contact forces {state}: an arrow per sole corner, "
                f"{FORCE_SCALE:g} m per body weight"
            )
        self.info.content = "\n\n".join([self._description, *lines])

    def _draw_waypoints(self, points: Array) -> None:
        for handle in self._waypoints:
            handle.remove()
        self._waypoints = []
        if not len(points):
            return
        scene = self.server.scene
        color = (30, 110, 240)
        visible = self.show_waypoints.value
        self._waypoints.append(
            scene.add_point_cloud(
                "/overlays/waypoints", points.astype(np.float32), color, point_size=0.06,
                point_shape="circle", precision="float32", visible=visible,
            )
        )  # fmt: skip
        if len(points) > 1:
            segments = np.stack([points[:-1], points[1:]], axis=1).astype(np.float32)
            self._waypoints.append(
                scene.add_line_segments(
                    "/overlays/waypoint_path", segments, color, thickness=0.01, visible=visible
                )
            )

    def _draw_terrain(self, patch: TerrainPatch | None) -> None:
        """The clip's terrain as a mesh of its height grid (none without one)."""
        if self._terrain is not None:
            self._terrain.remove()
            self._terrain = None
        if patch is None:
            return
        vertices, faces = grid_mesh(patch)
        self._terrain = self.server.scene.add_mesh_simple(
            "/terrain", vertices, faces, color=TERRAIN_COLOR, flat_shading=True,
            side="double", visible=self.show_terrain.value,
        )  # fmt: skip

    def _draw_plots(self, motion: Trajectory) -> None:
        self.plots.remove()
        gui = self.server.gui
        self.plots = gui.add_folder("Plots", expand_by_default=False)
        rows = np.unique(np.linspace(0, motion.frames - 1, PLOT_POINTS).astype(int))
        time = motion.time[rows].astype(float)
        groups = {
            "legs [rad]": [i for i, n in enumerate(motion.joint_names) if _is_leg(n)],
            "torso and arms [rad]": [i for i, n in enumerate(motion.joint_names) if not _is_leg(n)],
        }
        with self.plots:
            for title, columns in groups.items():
                if columns:
                    series = [motion.joint_names[c] for c in columns]
                    values = [motion.joint_positions[rows, c].astype(float) for c in columns]
                    _plot(gui, title, time, series, values)
            if motion.thrust.shape[1]:
                t_max = self.t_max
                shares = [motion.thrust[rows, j] / t_max[j] for j in range(len(t_max))]
                _plot(gui, "thrust T/T_max", time, list(motion.jet_names), shares)
            engines = engine_shares(motion, self.t_max)
            self.lag_plots = []
            if engines is not None:
                throttle, thrust = engines
                for j, name in enumerate(motion.jet_names):
                    plot = lag_plot(gui, name, time, throttle[rows, j], thrust[rows, j])
                    self.lag_plots.append(plot)

    def _show(self, frame: int) -> None:
        motion = self.motion
        assert motion is not None
        state = FrameState(
            motion.base_position[frame],
            motion.base_orientation[frame],
            motion.joint_positions[frame],
            motion.thrust[frame],
            motion.contacts[frame],
            None if self.forces is None else self.forces[frame],
        )
        with self.server.atomic():
            self.scene.show(state)
            if self.engines is not None:
                assert motion.throttle is not None
                self.engines.show(motion.throttle[frame], motion.thrust[frame])
            if self.skeleton is not None and self.skeleton.visible:
                assert motion.landmarks is not None
                self.skeleton.show(motion.landmarks[frame])

    # -- robot alone ---------------------------------------------------------------------------
    def _build_robot_only(self) -> None:
        gui, robot = self.server.gui, self.robot
        posture = robot.spec.posture_angles()
        limits = robot.limits
        gui.add_markdown(
            f"**{literal(robot.name)}** (model {robot.model_hash}): {len(robot.joint_names)} "
            f"joints, {robot.total_mass:.2f} kg\n\n{literal(robot.origin)}"
            + "".join(f"\n\n⚠ {literal(w)}" for w in self.warnings if w)
        )
        self.joint_sliders: dict[str, viser.GuiInputHandle[float]] = {}
        with gui.add_folder("Joints [rad]"):
            for i, name in enumerate(robot.joint_names):
                lower, upper = float(limits.lower[i]), float(limits.upper[i])
                if not lower < upper:  # continuous joint
                    lower, upper = -np.pi, np.pi
                start = min(max(posture[name], lower), upper)
                slider = gui.add_slider(name, lower, upper, 0.001, start)
                slider.on_update(lambda _: self._pose_robot())
                self.joint_sliders[name] = slider
            reset = gui.add_button("standing posture")
        self.show_frames = gui.add_checkbox("named frames", True)
        self.named_frames = frames = tuple(dict.fromkeys(robot.spec.frames))  # hands may be jets
        self._axes = self.server.scene.add_batched_axes(
            "/frames", np.tile([1.0, 0, 0, 0], (len(frames), 1)), np.zeros((len(frames), 3)),
            axes_length=0.06, axes_radius=0.004,
        )  # fmt: skip
        self._labels = [
            self.server.scene.add_label(f"/frame_labels/{name}", name, font_screen_scale=0.7)
            for name in frames
        ]

        @reset.on_click
        def _(_: viser.GuiEvent) -> None:
            for joint, slider in self.joint_sliders.items():
                slider.value = posture[joint]

        @self.show_frames.on_update
        def _(_: viser.GuiEvent) -> None:
            self._axes.visible = self.show_frames.value
            for label in self._labels:
                label.visible = self.show_frames.value

        # stand the base so that the lowest sole is on the floor at the standing posture
        q = np.array([posture[n] for n in robot.joint_names])
        poses = self.scene.poser.poses(np.zeros(3), np.array([1.0, 0, 0, 0]), q)
        soles = [self.scene.poser.index[foot.sole] for foot in robot.spec.feet]
        self._base = np.array([0.0, 0.0, -poses[soles, 2, 3].min()])
        self._pose_robot()
        forward = np.array(robot.spec.forward)  # seen from the front, a little to its left
        offset = 1.6 * forward + 1.6 * np.cross([0.0, 0.0, 1.0], forward) + [0.0, 0.0, 0.5]
        self.server.initial_camera.look_at = tuple(self._base * 0.8)
        self.server.initial_camera.position = tuple(self._base * 0.8 + offset)

    def _pose_robot(self) -> None:
        from motionkit.viewer.posing import matrices_to_quats

        robot = self.robot
        q = np.array([self.joint_sliders[n].value for n in robot.joint_names])
        with self._lock:
            poses = self.scene.show(FrameState(self._base, np.array([1.0, 0, 0, 0]), q))
            frames = poses[[self.scene.poser.index[f] for f in self.named_frames]]
            self._axes.batched_positions = frames[:, :3, 3].astype(np.float32)
            self._axes.batched_wxyzs = matrices_to_quats(frames[:, :3, :3]).astype(np.float32)
            for label, pose in zip(self._labels, frames, strict=True):
                label.position = pose[:3, 3]

    # -- the playback thread -------------------------------------------------------------------
    def _run(self) -> None:
        """Advance playing clips with the wall clock; keep the slider and camera in step."""
        self._tick_reference = clock.perf_counter()
        slider_shown = follow_shown = 0.0
        while not self._closed.is_set():
            playback = self.playback
            rate = min(self.rate, MAX_TICK_RATE)
            period = 1.0 / rate if rate > 0 else 1.0 / MAX_TICK_RATE
            now = clock.perf_counter()
            if playback is not None and playback.playing:
                with self._lock:
                    before = playback.frame
                    frame = playback.advance(now - self._tick_reference)
                    if frame != before:
                        self._show(frame)
                    if now - slider_shown >= 1.0 / SLIDER_RATE or not playback.playing:
                        self.slider.value = playback.now
                        slider_shown = now
                    if not playback.playing:
                        self.play_button.label = "Play"
            self._tick_reference = now
            if playback is not None and now - follow_shown >= 1.0 / FOLLOW_RATE:
                follow_shown = now
                self._follow()
            self._closed.wait(max(0.0, period - (clock.perf_counter() - now)))

    def _follow(self) -> None:
        """Move each client's camera with the robot's base, keeping the camera's offset."""
        if not self.follow.value or self.scene.state is None:
            return
        target = np.asarray(self.scene.state.base_position, dtype=float)
        for client in self.server.get_clients().values():
            camera = client.camera
            look_at = np.asarray(camera.look_at, dtype=float)
            if np.linalg.norm(target - look_at) > 0.01:
                with client.atomic():
                    camera.position = np.asarray(camera.position) + (target - look_at)
                    camera.look_at = target


def _is_leg(joint: str) -> bool:
    return any(word in joint for word in ("hip", "knee", "ankle", "leg", "foot"))


PALETTE = (
    "#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b", "#e377c2", "#7f7f7f",
    "#bcbd22", "#17becf", "#393b79", "#637939", "#8c6d31", "#843c39", "#7b4173",
)  # fmt: skip


def _plot(
    gui: viser.GuiApi, title: str, time: Array, names: list[str], values: list[Array]
) -> None:
    series = [viser.uplot.Series(label="time [s]")] + [
        viser.uplot.Series(label=name, stroke=PALETTE[k % len(PALETTE)], width=1)
        for k, name in enumerate(names)
    ]
    gui.add_uplot((time, *values), tuple(series), title=title, aspect=1.6)
