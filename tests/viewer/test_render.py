"""`motionkit render`: a clip drawn into a GIF with MuJoCo's offscreen renderer; the robot where
the camera projects its base, flames on firing jets, waypoints; frame choice, GIF delays; one-line
errors for bad clips and options with nothing written. Tests that draw skip without OpenGL."""

from __future__ import annotations

import itertools
import os
import sys
from collections.abc import Iterator
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from motionkit.cli import main
from motionkit.core.errors import ViewerError
from motionkit.dataset import Trajectory, write
from motionkit.dataset.synthetic import synthetic_trajectory
from motionkit.robot import Robot, ironcub
from motionkit.viewer.animation import gif_delays
from motionkit.viewer.offscreen import ROBOT_GROUP, ClipRenderer, check_gl, default_gl
from motionkit.viewer.render import RenderConfig, frame_indices, render_clip

pytest.importorskip("mujoco")
pytest.importorskip("trimesh")
SMALL = ["--width", "160", "--height", "120"]


@pytest.fixture(scope="module")
def robot() -> Robot:
    return ironcub()


@pytest.fixture(scope="module")
def motion(robot: Robot) -> Trajectory:
    """1 s at 30 Hz, walking on a circle at 0.5 m/s with 100 N per jet; a rollout's waypoints."""
    motion = synthetic_trajectory(robot, 1.0, 30.0, thrust=100.0)
    rows = [[0.0, 1.0, 0.5, 0.6], [0.5, 2.0, -1.0, 1.5]]  # [time, x, y, z], as `play` writes
    return replace(motion, metadata=replace(motion.metadata, config={"waypoints": rows}))


@pytest.fixture(scope="module")
def clip(motion: Trajectory, robot: Robot, tmp_path_factory: pytest.TempPathFactory) -> Path:
    return write(tmp_path_factory.mktemp("clips") / "walk.mcap", motion, robot)


@pytest.fixture(scope="module")
def gl() -> None:
    """Skip when no OpenGL context can be made (CI without EGL)."""
    try:
        check_gl()
    except ViewerError as exc:
        pytest.skip(f"no OpenGL context: {exc}")


@pytest.fixture(scope="module")
def renderer(gl: None, robot: Robot) -> Iterator[ClipRenderer]:
    from motionkit.viewer.meshes import robot_meshes

    config = RenderConfig(width=160, height=120, shadows=False)
    with ClipRenderer(robot, config, robot_meshes(robot)[0]) as renderer:
        yield renderer


def gif_frames(path: Path) -> list[np.ndarray]:
    from PIL import Image, ImageSequence

    with Image.open(path) as image:
        return [np.asarray(frame.convert("RGB")) for frame in ImageSequence.Iterator(image)]


def test_render_writes_a_gif_of_moving_pictures(
    gl: None, clip: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "walk.gif"
    assert main(["render", str(clip), "--out", str(out), "--fps", "10", *SMALL]) == 0
    printed = capsys.readouterr().out
    assert f"wrote {out}: 10 frames at 10 fps, 160x120" in printed and "ms per frame" in printed
    frames = gif_frames(out)
    assert len(frames) == 10 and frames[0].shape == (120, 160, 3)
    below_label = [frame[30:].astype(int) for frame in frames]
    for before, after in itertools.pairwise(below_label):
        assert np.abs(after - before).max() > 60  # the robot moved
    assert [p.name for p in tmp_path.iterdir()] == ["walk.gif"]  # no temporary left


def test_render_clip_prints_nothing_and_reports_progress(
    gl: None, clip: Path, robot: Robot, tmp_path: Path, capfd: pytest.CaptureFixture[str]
) -> None:
    config = RenderConfig(fps=5, width=160, height=120, start=0.2, seconds=0.6)
    lines: list[str] = []
    capfd.readouterr()
    rendered = render_clip(clip, tmp_path / "cut.gif", robot, config, progress=lines.append)
    assert capfd.readouterr() == ("", "")
    assert (rendered.frames, rendered.start, rendered.warnings) == (4, pytest.approx(0.2), ())
    assert rendered.seconds == pytest.approx(0.6) and rendered.seconds_per_frame > 0
    assert lines[-1].startswith("drew 4/4 frames (") and len(gif_frames(rendered.path)) == 4


def project(renderer: ClipRenderer, point: np.ndarray) -> tuple[float, float]:
    """(column, row) of a world point in the last picture, from the scene's OpenGL camera."""
    camera = renderer.scene.camera[0]
    forward, up = np.array(camera.forward), np.array(camera.up)
    eyes = np.mean([c.pos for c in renderer.scene.camera], axis=0)  # a mono picture: between
    offset = np.asarray(point) - eyes
    scale = camera.frustum_near / (offset @ forward)  # onto the near plane
    x, y = offset @ np.cross(forward, up) * scale, offset @ up * scale
    top, bottom = camera.frustum_top, camera.frustum_bottom
    width, height = renderer.config.width, renderer.config.height
    pixel = height / (top - bottom)  # pixels per unit of the near plane
    return width / 2 + (x - camera.frustum_center) * pixel, (top - y) * pixel


def robot_mask(renderer: ClipRenderer, qpos: np.ndarray) -> np.ndarray:
    """The pixels the robot changes: the picture with it against the picture without."""
    thrust = np.zeros(len(renderer.jet_sites))
    shown = renderer.picture(qpos, thrust).astype(int)
    renderer.option.geomgroup[ROBOT_GROUP] = 0
    try:
        empty = renderer.picture(qpos, thrust).astype(int)
    finally:
        renderer.option.geomgroup[ROBOT_GROUP] = 1
    return np.abs(shown - empty).sum(axis=2) > 3  # the same pixel unless the robot covers it


def test_the_robot_is_drawn_where_its_base_projects(
    renderer: ClipRenderer, motion: Trajectory
) -> None:
    """The camera follows the base: wherever it is, it projects to the image centre, and the
    robot's pixels (standing, its pelvis on the base) cover it."""
    standing = renderer.model.key_qpos[0][7:]
    for index in (0, motion.frames - 1):  # 0.5 m apart
        base = motion.base_position[index]
        mask = robot_mask(
            renderer, np.concatenate([base, motion.base_orientation[index], standing])
        )
        column, row = project(renderer, base)
        assert abs(column - 80) < 1 and abs(row - 60) < 1
        assert mask[round(row) - 2 : round(row) + 3, round(column) - 2 : round(column) + 3].all()
        rows, columns = np.nonzero(mask)
        assert 0.02 < mask.mean() < 0.5  # a robot, not a speck nor the whole picture
        assert rows.min() < row < rows.max() and columns.min() < column < columns.max()


def test_firing_jets_draw_flames(renderer: ClipRenderer, robot: Robot) -> None:
    qpos = renderer.model.key_qpos[0]
    t_max = np.array([jet.t_max for jet in robot.spec.jets])
    cold = renderer.picture(qpos, np.zeros_like(t_max)).astype(int)
    half = renderer.picture(qpos, 0.5 * t_max).astype(int)
    full = renderer.picture(qpos, t_max).astype(int)
    flames = np.abs(full - cold).sum(axis=2) > 60
    red, green, blue = full[flames].mean(axis=0)
    assert flames.sum() > 30 and red > green > blue and red - blue > 80  # orange
    assert (np.abs(half - cold).sum(axis=2) > 60).sum() < flames.sum()  # shorter at half thrust


def test_waypoints_are_drawn(gl: None, robot: Robot, motion: Trajectory) -> None:
    """A blue ball on a pole where the waypoint is."""
    from motionkit.viewer.meshes import robot_meshes

    config = RenderConfig(width=160, height=120, shadows=False)
    state = [motion.base_position[0], motion.base_orientation[0], motion.joint_positions[0]]
    qpos, thrust = np.concatenate(state), np.zeros(len(robot.spec.jets))
    point = motion.base_position[0] + [0.0, 0.0, 0.8]  # above the robot: never hidden by it
    blue = []
    for points in (None, [point]):
        with ClipRenderer(robot, config, robot_meshes(robot)[0], points) as renderer:
            picture = renderer.picture(qpos, thrust).astype(int)
        blue.append((picture[..., 2] - picture[..., 0] > 80) & (picture[..., 2] > picture[..., 1]))
    ball = blue[1] & ~blue[0]
    assert ball.sum() >= 4 and not (blue[0] & ~blue[1]).any()
    rows, columns = np.nonzero(ball)
    column, row = project(renderer, point)
    assert abs(columns.mean() - column) < 3 and abs(rows.mean() - row) < 3


def test_frames_are_picked_every_1_over_fps_seconds() -> None:
    time = np.arange(30) / 30.0  # 1 s at 30 Hz
    assert frame_indices(time, RenderConfig(fps=10)).tolist() == list(range(0, 30, 3))
    assert frame_indices(time, RenderConfig(fps=7)).tolist() == [0, 4, 8, 12, 17, 21, 25]
    cut = RenderConfig(fps=10, start=0.5, seconds=0.2)
    assert frame_indices(time, cut).tolist() == [15, 18, 21]
    assert frame_indices(time + 5.0, cut).tolist() == [15, 18, 21]  # from the clip's first frame
    assert frame_indices(time, RenderConfig(fps=10, seconds=60)).tolist()[-1] == 27
    with pytest.raises(ViewerError, match=r"--start 2 s is past the end of the clip"):
        frame_indices(time, RenderConfig(start=2.0))


def test_gif_delays_keep_the_rate() -> None:
    assert gif_delays(30.0, 6) == [30, 40, 30, 30, 40, 30]  # 200 ms: 6 / 30 s
    assert sum(gif_delays(24.0, 240)) == 10_000
    assert gif_delays(10.0, 3) == [100, 100, 100]


def test_config_refuses_bad_values() -> None:
    for bad, field in (
        ({"fps": 0.0}, "'fps'"),
        ({"fps": float("nan")}, "'fps'"),
        ({"width": 8}, "'width'"),
        ({"height": 100.5}, "'height'"),
        ({"start": -1.0}, "'start'"),
        ({"seconds": 0.0}, "'seconds'"),
        ({"elevation": 90.0}, "'elevation'"),
    ):
        with pytest.raises(ViewerError, match=field):
            RenderConfig(**bad)


@pytest.mark.parametrize(
    ("name", "content", "options", "message"),
    [
        ("missing.mcap", None, [], "no such file"),
        ("garbage.mcap", b"not a clip at all", [], "garbage.mcap"),
        ("truncated.mcap", "half", [], "truncated.mcap"),
        ("walk.mcap", "clip", ["--fps", "0"], "'fps' should be finite and > 0"),
        ("walk.mcap", "clip", ["--width", "7"], "'width' should be a whole number"),
        ("walk.mcap", "clip", ["--start", "5"], "--start 5 s is past the end"),
        ("walk.mcap", "clip", ["--fps", "60"], "a GIF shows at most 50 frames per second"),
    ],
)
def test_bad_clips_and_options_exit_with_one_line_and_write_nothing(
    clip: Path,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    name: str,
    content: bytes | str | None,
    options: list[str],
    message: str,
) -> None:
    path = tmp_path / name
    if content == "clip":
        path = clip
    elif content == "half":
        data = clip.read_bytes()
        path.write_bytes(data[: len(data) // 2])
    elif content is not None:
        path.write_bytes(content)
    out = tmp_path / "out" / "picture.gif"
    assert main(["render", str(path), "--out", str(out), *options]) == 2
    err = capsys.readouterr().err
    assert err.startswith("motionkit: error: ") and err.count("\n") == 1, err
    assert message in err and "Traceback" not in err
    assert not out.parent.exists()


def test_bad_output_names_are_refused(
    clip: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["render", str(clip), "--out", str(tmp_path / "picture.png")]) == 2
    assert "expected a .gif or .mp4 file name" in capsys.readouterr().err
    assert main(["render", str(clip), "--out", str(tmp_path)]) == 2
    assert "expected a .gif or .mp4" in capsys.readouterr().err
    assert main(["render", str(clip), "--out", str(tmp_path / "odd.mp4"), "--width", "161"]) == 2
    assert "even width and height" in capsys.readouterr().err
    assert sorted(p.name for p in tmp_path.iterdir()) == []


def test_mp4_without_an_encoder_names_what_to_install(
    clip: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setitem(sys.modules, "imageio_ffmpeg", None)  # an import of it now fails
    assert main(["render", str(clip), "--out", str(tmp_path / "walk.mp4")]) == 2
    err = capsys.readouterr().err
    assert "writing an MP4 needs an ffmpeg encoder: pip install imageio-ffmpeg" in err
    assert not (tmp_path / "walk.mp4").exists()


def test_mp4_is_written_when_an_encoder_is_there(gl: None, clip: Path, tmp_path: Path) -> None:
    pytest.importorskip("imageio_ffmpeg")
    out = tmp_path / "walk.mp4"
    assert main(["render", str(clip), "--out", str(out), "--fps", "10", *SMALL]) == 0
    assert out.read_bytes()[4:8] == b"ftyp" and [p.name for p in tmp_path.iterdir()] == [out.name]


def test_a_failure_while_drawing_keeps_the_old_file(
    gl: None, clip: Path, robot: Robot, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    out = tmp_path / "walk.gif"
    out.write_bytes(b"the previous picture")
    drawn = []

    def draw(self: ClipRenderer, motion: Trajectory, index: int, title: str = "") -> np.ndarray:
        if len(drawn) == 3:
            raise ViewerError("the renderer broke")
        drawn.append(index)
        return np.zeros((120, 160, 3), np.uint8)

    monkeypatch.setattr(ClipRenderer, "draw", draw)
    with pytest.raises(ViewerError, match="the renderer broke"):
        render_clip(clip, out, robot, RenderConfig(fps=10, width=160, height=120))
    assert out.read_bytes() == b"the previous picture"
    assert [p.name for p in tmp_path.iterdir()] == ["walk.gif"]


def test_no_opengl_names_what_to_install(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("MUJOCO_GL", "egl")
    monkeypatch.setitem(sys.modules, "mujoco.egl", None)  # as if EGL could not be loaded
    with pytest.raises(ViewerError) as caught:
        check_gl()
    message = str(caught.value)
    assert message.startswith("no OpenGL context for MuJoCo's offscreen renderer (MUJOCO_GL=egl")
    assert "apt-get install libegl1 libgl1-mesa-dri" in message and "\n" not in message


def test_a_backend_that_breaks_the_import_of_mujoco_is_one_line(clip: Path, tmp_path: Path) -> None:
    """mujoco imports its OpenGL backend and lets only an ImportError pass (an invalid
    MUJOCO_GL raises a RuntimeError): a fresh interpreter, where mujoco is not imported yet."""
    import subprocess

    out = tmp_path / "walk.gif"
    code = f"from motionkit.cli import main; main(['render', {str(clip)!r}, '--out', {str(out)!r}])"
    env = {**os.environ, "MUJOCO_GL": "no-such-backend"}
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env)
    assert (
        done.stderr.startswith("motionkit: error: no OpenGL context")
        and "Traceback" not in done.stderr
    )
    assert "MUJOCO_GL=no-such-backend" in done.stderr and done.stderr.count("\n") == 1
    assert not out.exists()


def test_egl_is_the_default_backend_on_linux(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv("MUJOCO_GL", raising=False)
    expected = "egl" if sys.platform.startswith("linux") else ""
    assert default_gl() == expected
    monkeypatch.setenv("MUJOCO_GL", "osmesa")
    assert default_gl() == "osmesa"  # a choice of the user's is kept


def test_render_takes_the_robot_like_every_command(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit):
        main(["render", "--help"])
    text = capsys.readouterr().out
    assert "--urdf URDF" in text and "--spec SPEC" in text and "imageio-ffmpeg" in text
