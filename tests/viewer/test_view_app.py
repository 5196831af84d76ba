"""ViewerApp without a browser: the player's timeline, real-time playback, clip picker and
overlays; the robot alone with a slider per joint."""

import time
from collections.abc import Iterator
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from viewer_support import free_port

pytest.importorskip("viser")

from motionkit.dataset import write
from motionkit.dataset.synthetic import synthetic_trajectory
from motionkit.robot import ironcub
from motionkit.viewer.app import ViewerApp
from motionkit.viewer.scene import CONTACT_COLOR, FREE_COLOR, THRUST_LENGTH
from motionkit.viewer.sources import resolve_clips


@pytest.fixture(scope="module")
def player(tmp_path_factory: pytest.TempPathFactory) -> Iterator[ViewerApp]:
    robot = ironcub()
    root = tmp_path_factory.mktemp("app")
    flight = synthetic_trajectory(robot, 3.0, thrust=125.0, kind="flight", seed=4)
    meta = replace(flight.metadata, config={"waypoints": [[0, 0, 1], [1, 1, 2]]})
    write(root / "flight.mcap", replace(flight, metadata=meta), robot)
    write(root / "walk.mcap", synthetic_trajectory(robot, 2.0, rate=60.0), robot)
    clips = sorted(resolve_clips(root), key=lambda c: c.name)  # flight first
    app = ViewerApp(robot, clips, port=free_port())
    yield app
    app.close()


def test_timeline_poses_the_robot_from_the_clip(player: ViewerApp) -> None:
    motion = player.motion
    assert player.set_time(1.5) == 180
    pose = player.current_pose()
    np.testing.assert_allclose(pose["root_link"][:3, 3], motion.base_position[180], atol=1e-6)
    foot = pose["l_foot"].copy()
    assert player.set_time(99.0) == motion.frames - 1  # clamped to the end
    assert player.slider.value == pytest.approx(motion.time[-1])
    assert np.abs(player.current_pose()["l_foot"][:3, 3] - foot[:3, 3]).max() > 0.05


def test_thrust_arrows_and_contact_markers(player: ViewerApp) -> None:
    player.set_time(0.0)  # thrust 125 N of 250 N: half-length arrows out of the four nozzles
    arrows = player.scene.thrust.points
    assert player.scene.thrust.visible and arrows.shape == (4, 2, 3)
    lengths = np.linalg.norm(arrows[:, 1] - arrows[:, 0], axis=1)
    np.testing.assert_allclose(lengths, 0.5 * THRUST_LENGTH, rtol=1e-5)
    nozzles = [player.scene.link_pose(jet.frame)[:3, 3] for jet in player.robot.spec.jets]
    np.testing.assert_allclose(arrows[:, 0], nozzles, atol=1e-6)
    contacts = player.motion.contacts[0]  # left down, right up at t = 0 (gait phase 0)
    colors = player.scene.contacts.colors
    assert contacts.tolist() == [True, False]
    assert (colors[:4] == CONTACT_COLOR).all() and (colors[4:] == FREE_COLOR).all()
    com = player.scene.com.position
    assert 0.3 < com[2] < 0.9 and not player.scene.forces.visible  # no planned forces


def test_waypoints_drawn(player: ViewerApp) -> None:
    cloud = player._waypoints[0]
    np.testing.assert_allclose(cloud.points, [[0, 0, 1], [1, 1, 2]])


def test_plays_at_real_time(player: ViewerApp) -> None:
    player.set_time(0.0)
    player.play()
    start = time.perf_counter()
    time.sleep(0.6)
    elapsed = time.perf_counter() - start
    player.play(False)
    assert player.playback.now == pytest.approx(elapsed, abs=0.1)
    assert player.frame == pytest.approx(120 * player.playback.now, abs=2)


def test_clip_picker_loads_the_other_clip(player: ViewerApp) -> None:
    assert player.picker.options == ("flight", "walk")
    player.select_clip(1)
    assert player.motion.frames == 120 and player.rate == pytest.approx(60.0)
    assert player.slider.max == pytest.approx(119 / 60) and not player._waypoints
    assert not player.scene.thrust.visible  # no thrust in the walk
    assert "**walk**" in player.info.content
    player.select_clip(0)
    assert player.motion.frames == 360


def test_robot_alone_has_a_slider_per_joint() -> None:
    robot = ironcub()
    app = ViewerApp(robot, port=free_port())
    try:
        assert list(app.joint_sliders) == list(robot.joint_names)
        knee = app.joint_sliders["l_knee"]
        index = robot.joint_names.index("l_knee")
        assert (knee.min, knee.max) == (robot.limits.lower[index], robot.limits.upper[index])
        assert knee.value == pytest.approx(-0.6)  # the standing posture
        soles = [app.scene.link_pose(foot.sole)[2, 3] for foot in robot.spec.feet]
        assert min(soles) == pytest.approx(0.0, abs=1e-9)  # standing on the floor
        assert [label.text for label in app._labels] == list(dict.fromkeys(robot.spec.frames))
        np.testing.assert_allclose(
            app._labels[0].position, app.scene.link_pose(robot.spec.root)[:3, 3], atol=1e-6
        )
        before = app.scene.link_pose("l_foot").copy()
        soles_before = [app.scene.link_pose("l_sole")[:3, 3].copy()]
        knee.value = -1.5
        after = app.scene.link_pose("l_foot")
        assert np.linalg.norm(after[:3, 3] - before[:3, 3]) > 0.05
        assert np.abs(app._labels[1].position - soles_before[0]).max() > 0.05  # l_sole moved
        with pytest.raises(Exception, match="robot alone"):
            app.set_time(1.0)
    finally:
        app.close()


def test_cli_robot_and_path_are_exclusive(tmp_path: Path, capsys) -> None:
    from motionkit.cli import main

    assert main(["view", str(tmp_path), "--robot"]) == 2
    assert "not both" in capsys.readouterr().err
