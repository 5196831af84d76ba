"""ViewerApp without a browser: the player's timeline, real-time playback, clip picker and
overlays (the human skeleton of retargeted clips, planned contact forces); the robot alone with a
slider per joint."""

import time
from collections.abc import Iterator
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from viewer_support import free_port

pytest.importorskip("viser")

from motionkit.dataset import corner_names, write
from motionkit.dataset.synthetic import synthetic_trajectory
from motionkit.mocap import LANDMARKS
from motionkit.mocap.naming import skeleton
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
    assert main(["view", str(tmp_path), "--skeleton-offset", "nan"]) == 2
    assert "--skeleton-offset must be a finite distance" in capsys.readouterr().err


# -- the human skeleton of retargeted clips and the contact forces of optimised flights --------
@pytest.fixture(scope="module")
def extras(tmp_path_factory: pytest.TempPathFactory) -> Iterator[ViewerApp]:
    """Clips a_human (landmarks), b_hop (contact forces) and c_plain (neither)."""
    robot = ironcub()
    root = tmp_path_factory.mktemp("extras")
    names, parents = skeleton(LANDMARKS)
    motion = synthetic_trajectory(robot, 1.0, seed=5)
    rng = np.random.default_rng(5)
    body = rng.uniform(-0.3, 0.3, (len(names), 3))  # a rigid "human" riding on the base
    human = motion.base_position[:, None, :] + body
    write(
        root / "a_human.mcap",
        replace(motion, landmark_names=names, landmark_parents=parents, landmarks=human),
        robot,
    )
    weight = robot.total_mass * 9.81
    forces = np.zeros((motion.frames, 8, 3))
    forces[:, :4] = [0.05 * weight, 0.0, weight / 4]  # the left foot carries the robot
    forces[:, 4:, 2] = 1e-4 * weight  # below the threshold: no arrow
    planned = replace(motion, corner_names=corner_names(robot), contact_forces=forces)
    write(root / "b_hop.mcap", planned, robot)
    write(root / "c_plain.mcap", motion, robot)
    clips = sorted(resolve_clips(root), key=lambda c: c.name)
    app = ViewerApp(robot, clips, port=free_port(), skeleton_offset=0.8)
    yield app
    app.close()


def test_skeleton_stands_beside_the_robot(extras: ViewerApp) -> None:
    extras.select_clip(0)
    motion, skeleton = extras.motion, extras.skeleton
    assert skeleton is not None and motion.landmarks is not None
    # iRonCub faces -x: its left is -y, where the base starts (yaw 0); 0.8 m from the option
    offset = np.array([0.0, -0.8, 0.0])
    np.testing.assert_allclose(skeleton.offset, offset, atol=1e-12)
    frame = extras.set_time(0.5)
    assert frame == 60
    points = motion.landmarks[frame] + offset
    np.testing.assert_allclose(skeleton.joints.batched_positions, points, atol=1e-6)
    bones = skeleton.bones.points  # one segment per landmark with a parent, parent first
    assert bones.shape == (len(LANDMARKS) - 1, 2, 3)
    knee, ankle = LANDMARKS.index("l_knee"), LANDMARKS.index("l_ankle")
    np.testing.assert_allclose(bones[ankle - 1], points[[knee, ankle]], atol=1e-6)
    assert skeleton.joints.visible and skeleton.bones.visible
    assert "human skeleton (19 landmarks, scaled to the robot) shown, 0.8 m" in extras.info.content
    assert "contact forces" not in extras.info.content and extras.show_forces.disabled
    assert not extras.scene.forces.visible

    extras.show_skeleton.value = False  # hidden: not posed while hidden, posed again when shown
    assert not skeleton.joints.visible and not skeleton.bones.visible
    assert "human skeleton (19 landmarks, scaled to the robot) hidden" in extras.info.content
    extras.set_time(0.25)
    np.testing.assert_allclose(skeleton.joints.batched_positions, points, atol=1e-6)
    extras.show_skeleton.value = True
    np.testing.assert_allclose(
        skeleton.joints.batched_positions, motion.landmarks[30] + offset, atol=1e-6
    )


def test_side_offset_turns_with_the_robot() -> None:
    from motionkit.viewer.skeleton import side_offset

    yaw = np.radians(90.0)  # facing -x turned left: facing -y, its left is +x
    quat = [np.cos(yaw / 2), 0.0, 0.0, np.sin(yaw / 2)]
    np.testing.assert_allclose(
        side_offset((-1.0, 0.0, 0.0), quat, 2.0), [2.0, 0.0, 0.0], atol=1e-12
    )
    pitched = [np.cos(np.pi / 8), 0.0, np.sin(np.pi / 8), 0.0]  # 45 deg pitch: left stays -y
    np.testing.assert_allclose(side_offset((1.0, 0.0, 0.0), pitched, 1.0), [0, 1.0, 0], atol=1e-12)


def test_contact_force_arrows_from_the_corners(extras: ViewerApp) -> None:
    extras.select_clip(1)
    assert extras.skeleton is None and extras.show_skeleton.disabled
    assert not extras.show_forces.disabled
    frame = extras.set_time(0.3)
    arrows = extras.scene.forces.points
    assert extras.scene.forces.visible and arrows.shape == (4, 2, 3)  # the right foot's are tiny
    corners = [extras.scene.link_pose(c)[:3, 3] for c in corner_names(extras.robot)[:4]]
    np.testing.assert_allclose(arrows[:, 0], corners, atol=1e-6)
    # 0.5 m per body weight: a quarter of the weight up, 5 % of it along +x
    np.testing.assert_allclose(arrows[:, 1] - arrows[:, 0], [[0.025, 0.0, 0.125]] * 4, atol=1e-6)
    assert extras.forces[frame, 0, 2] == pytest.approx(extras.robot.total_mass * 9.81 / 4, rel=1e-6)
    assert "planned contact forces shown" in extras.info.content
    extras.show_forces.value = False
    assert not extras.scene.forces.visible
    assert "planned contact forces hidden" in extras.info.content
    extras.show_forces.value = True
    assert extras.scene.forces.visible


def test_plain_clip_has_neither(extras: ViewerApp) -> None:
    extras.select_clip(1)
    extras.select_clip(2)
    scene = extras.server.scene
    assert extras.skeleton is None and extras.forces is None
    assert scene.get_handle_by_name("/overlays/skeleton/joints") is None  # removed
    assert not extras.scene.forces.visible
    assert extras.show_skeleton.disabled and extras.show_forces.disabled
    assert "skeleton" not in extras.info.content and "contact forces" not in extras.info.content
    extras.select_clip(0)  # the skeleton is back
    assert extras.skeleton is not None
    assert scene.get_handle_by_name("/overlays/skeleton/joints") is extras.skeleton.joints
