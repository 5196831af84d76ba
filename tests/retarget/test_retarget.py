"""The retargeter on a synthetic walker: clean contacts, limits, tracking; a valid clip that
holds the scaled human it was retargeted to."""

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from walker import HIP_Y, SHANK, THIGH, walker

from motionkit import recipes
from motionkit.core.errors import RetargetError
from motionkit.dataset import read, write
from motionkit.dataset.validate import validate_clip
from motionkit.retarget.config import RetargetConfig
from motionkit.retarget.metrics import segment_distance
from motionkit.robot import ironcub

pytest.importorskip("placo")
from motionkit.retarget.core import retarget


@pytest.fixture(scope="module")
def result():
    landmarks, rate = walker(3.0)
    trajectory, _ = retarget(landmarks, rate, ironcub(), RetargetConfig())
    return landmarks, trajectory


def test_walker_retargets_cleanly(result) -> None:
    _, trajectory = result
    m = trajectory.metadata.metrics
    assert m["foot_slide_p95_m_s"] <= 0.003  # the walker's own feet slide ~9 cm/s at contact edges
    assert m["penetration_max_m"] <= 0.001
    assert m["joint_position_violations"] == 0 and m["joint_velocity_violations"] == 0
    assert m["feet_error_mean_m"] <= 0.03 and m["knees_error_mean_m"] <= 0.03
    robot = ironcub()
    leg = np.linalg.norm(
        robot.model.link_poses()["l_lower_leg"][:3, 3]
        - robot.model.link_poses()["l_ankle_1"][:3, 3]
    )
    assert leg == pytest.approx(0.2005, abs=1e-4)  # iCub shank, the scale's denominator side
    assert m["scale"] == pytest.approx((0.2345254 + 0.2005) / (THIGH + SHANK), rel=1e-3)


def test_contacts_follow_the_stance_phases(result) -> None:
    landmarks, trajectory = result
    lifted = np.stack([landmarks[f"{s}_ankle"][:, 2] > 0.08 + 1e-9 for s in "lr"], axis=1)
    agreement = (trajectory.contacts == ~lifted).mean()
    assert agreement >= 0.9


def test_output_is_a_valid_clip(result, tmp_path: Path) -> None:
    _, trajectory = result
    robot = ironcub()
    checks = validate_clip(write(tmp_path / "walk.mcap", trajectory, robot), robot)
    failed = [c for c in checks if not c.ok and not c.warning]
    assert not failed, failed
    assert trajectory.metadata.generator == "retarget" and trajectory.metadata.kind == "walk"


def test_clip_holds_the_scaled_human_it_was_retargeted_to(result, tmp_path: Path) -> None:
    from motionkit.core.filters import low_pass
    from motionkit.mocap import LANDMARKS
    from motionkit.retarget.metrics import Kinematics
    from motionkit.retarget.points import robot_points
    from motionkit.retarget.targets import RobotGeometry
    from motionkit.robot.geometry import to_rotation

    landmarks, trajectory = result
    robot, config = ironcub(), RetargetConfig()
    clip = read(write(tmp_path / "walk.mcap", trajectory, robot))
    names, parents, human = clip.landmark_names, clip.landmark_parents, clip.landmarks
    assert names == LANDMARKS and human.shape == (trajectory.frames, 19, 3)
    # parents form one tree rooted at the pelvis (parents come first: no cycles)
    assert parents.count(-1) == 1 and parents[0] == -1
    assert all(-1 < p < i for i, p in enumerate(parents) if i)
    bone = {names[i]: names[p] for i, p in enumerate(parents) if p >= 0}
    assert bone["l_ankle"] == "l_knee" and bone["r_hip"] == "pelvis"
    assert bone["l_shoulder"] == "neck" and bone["head"] == "neck"

    # the low-passed walker scaled about the origin and lifted: one offset (0, 0, lift) for all
    scale = trajectory.metadata.metrics["scale"]
    source = np.stack([low_pass(landmarks[n], 120.0, config.smoothing_hz) for n in names], 1)
    offset = (human - scale * source).reshape(-1, 3)
    np.testing.assert_allclose(offset, np.tile(offset[0], (len(offset), 1)), atol=1e-6)
    assert offset[0, :2] == pytest.approx([0.0, 0.0], abs=1e-6)
    at = {name: human[:, i].astype(float) for i, name in enumerate(names)}
    legs = [
        np.linalg.norm(at[f"{s}_knee"] - at[f"{s}_hip"], axis=1)
        + np.linalg.norm(at[f"{s}_ankle"] - at[f"{s}_knee"], axis=1)
        for s in "lr"
    ]
    assert np.median(np.concatenate(legs)) == pytest.approx(0.2345254 + 0.2005, abs=1e-5)
    # ankles in contact at the robot's ankle height above its sole (the lift's definition)
    points = robot_points(robot, config.points)
    geometry = RobotGeometry(robot, points, config.points.torso_frame)
    contacts = trajectory.contacts
    heights = np.concatenate([at[f"{s}_ankle"][contacts[:, k], 2] for k, s in enumerate("lr")])
    assert np.median(heights) == pytest.approx(geometry.ankle_height, abs=1e-6)

    # the robot's ankles where the human's are in contact. The robot is rebuilt with its own
    # segments along the human's: its ankle differs from the scaled one by the hip offset
    # (robot hip half-width vs the scaled human's, lateral) plus (thigh - shank) x the difference
    # of the thigh and shank directions (3.4 cm x knee bend, forward and up), plus IK tracking.
    base = np.broadcast_to(np.eye(4), (trajectory.frames, 4, 4)).copy()
    base[:, :3, :3] = to_rotation(trajectory.base_orientation.astype(float)).as_matrix()
    base[:, :3, 3] = trajectory.base_position
    kinematics = Kinematics(robot, base, trajectory.joint_positions.astype(float))
    lateral = abs(geometry.hip[0, 1]) - scale * HIP_Y  # m, 2.4 cm
    assert 0.02 < lateral < 0.03
    for k, s in enumerate("lr"):
        error = np.abs(kinematics.point(points[f"{s}_ankle"]) - at[f"{s}_ankle"])[contacts[:, k]]
        assert error[:, 0].max() < 0.02 and error[:, 2].max() < 0.02
        assert error[:, 1].max() < lateral + 0.005


def test_missing_landmarks_and_bad_config() -> None:
    landmarks, rate = walker(0.5)
    del landmarks["l_knee"]
    with pytest.raises(RetargetError, match="lacks landmarks \\['l_knee'\\]"):
        retarget(landmarks, rate, ironcub(), RetargetConfig())
    with pytest.raises(RetargetError, match="unknown keys \\['knee_weight'\\]"):
        RetargetConfig.from_dict({"knee_weight": 1.0})
    with pytest.raises(RetargetError, match="'iterations' should be int"):
        RetargetConfig.from_dict({"iterations": "two"})


def test_segment_distance_by_hand() -> None:
    zero = np.zeros((1, 3))
    x, y = np.array([[1.0, 0.0, 0.0]]), np.array([[0.0, 0.5, 0.0]])
    # parallel segments 0.5 apart; crossing segments 0.2 apart; end point to segment
    assert segment_distance(zero, x, zero + y, x + y)[0] == pytest.approx(0.5)
    crossing = segment_distance(zero - x, x, np.array([[0, -1, 0.2]]), np.array([[0, 1, 0.2]]))
    assert crossing[0] == pytest.approx(0.2)
    beyond = segment_distance(zero, x, np.array([[2.0, 0, 0]]), np.array([[3.0, 0, 0]]))
    assert beyond[0] == pytest.approx(1.0)


def test_low_pass_keeps_gait_and_drops_jitter() -> None:
    from motionkit.core.filters import low_pass

    rate = 120.0
    t = np.arange(600) / rate
    slow, fast = np.sin(2 * np.pi * 1.0 * t), np.sin(2 * np.pi * 30.0 * t)
    out = low_pass(np.stack([slow, fast], axis=1), rate, 6.0)
    middle = slice(120, 480)  # away from the padded ends
    # 2nd-order Butterworth run forward and back: gain 1 / (1 + (f / fc)^4)
    assert np.abs(out[middle, 0]).max() == pytest.approx(1 / (1 + (1 / 6) ** 4), abs=2e-3)
    assert np.abs(out[middle, 1]).max() == pytest.approx(1 / (1 + 5**4), abs=2e-3)
    assert np.array_equal(low_pass(slow[:5], rate, 6.0), slow[:5])  # too short: unchanged


def test_sole_target_defined_when_the_foot_points_down() -> None:
    """At toe-off the human foot can point straight down: its heading is then undefined, but the
    ankle's pitch axis (shank x foot) is not, and the sole target turns smoothly through it."""
    from motionkit.retarget.points import robot_points
    from motionkit.retarget.targets import RobotGeometry, _sole_targets

    robot = ironcub()
    config = RetargetConfig()
    geometry = RobotGeometry(robot, robot_points(robot, config.points), "chest")
    frames = 61
    pitch = np.linspace(0.0, np.pi / 2, frames)  # foot from flat to straight down, heading +x
    foot = 0.12 * np.stack([np.cos(pitch), np.zeros(frames), -np.sin(pitch)], axis=1)
    shank = np.tile([0.0, 0.0, 0.4], (frames, 1))
    contact = np.zeros(frames, dtype=bool)
    ankle = np.tile([0.0, 0.0, 0.3], (frames, 1))
    soles, hold = _sole_targets(ankle, foot, shank, contact, 0, geometry, config, 120.0)
    assert np.isfinite(soles).all() and not hold.any()
    turn = np.einsum("tji,tjk->tik", soles[:-1, :3, :3], soles[1:, :3, :3])
    step = np.arccos(np.clip((np.trace(turn, axis1=1, axis2=2) - 1) / 2, -1, 1))
    assert step.max() < 2 * (np.pi / 2) / (frames - 1)  # no jump anywhere, also at the end


def test_recipes_parse() -> None:
    found = recipes.builtin("retarget")
    assert {r.name for r in found} >= {"cmu_walk", "sample_walks"}
    for recipe in (r.path for r in found):
        config = RetargetConfig.from_toml(recipe)
        assert config.clips and config.kind == "walk"


def test_slowdown_stretches_time_and_keeps_the_poses() -> None:
    landmarks, rate = walker(1.0)
    config = RetargetConfig(balance=replace(RetargetConfig().balance, passes=0))
    normal, _ = retarget(landmarks, rate, ironcub(), config)
    slow, _ = retarget(landmarks, rate, ironcub(), replace(config, slowdown=2.0))
    assert slow.time[-1] == pytest.approx(2 * normal.time[-1])
    assert slow.metadata.metrics["slowdown"] == 2.0
    assert np.abs(slow.joint_positions - normal.joint_positions).mean() < 0.01  # rad
    fast = np.abs(normal.joint_velocities).mean()
    assert np.abs(slow.joint_velocities).mean() == pytest.approx(fast / 2, rel=0.05)
    with pytest.raises(RetargetError, match="slowdown"):
        RetargetConfig(slowdown=0.0)


@pytest.mark.parametrize("clearance", [0.0, 0.02])
def test_a_swinging_sole_clears_the_floor(clearance: float) -> None:
    """A foot that stands, then drags along the floor (toe-off): its sole target sits on the
    floor in contact and rises to `clearance` above it over the release time, as a smoothstep
    (3 u^2 - 2 u^3 of the share u of the release time gone by)."""
    from motionkit.retarget.points import robot_points
    from motionkit.retarget.targets import RobotGeometry, _sole_targets

    robot = ironcub()
    config = RetargetConfig(swing_clearance=clearance)
    geometry = RobotGeometry(robot, robot_points(robot, config.points), "chest")
    rate, frames = 100.0, 100
    ankle = np.column_stack([np.linspace(0.0, 0.5, frames), np.zeros((frames, 2))])  # on the floor
    foot = np.tile([0.12, 0.0, 0.0], (frames, 1))
    shank = np.tile([0.0, 0.0, 0.4], (frames, 1))
    contact = np.arange(frames) < 40
    soles, _ = _sole_targets(ankle, foot, shank, contact, 0, geometry, config, rate)
    corners = np.einsum("tij,cj->tci", soles[:, :3, :3], geometry.corners[0])[..., 2]
    lowest = corners.min(axis=1) + soles[:, 2, 3]
    window = round(config.release_time * rate)  # 20 frames
    assert np.allclose(lowest[:40], 0.0, atol=1e-9)
    assert np.allclose(lowest[40 + window :], clearance, atol=1e-9)
    blend = lowest[40 : 40 + window]  # the weight of the human's height: a smoothstep
    u = np.arange(1, window + 1) / window
    assert np.allclose(blend, clearance * (3 * u**2 - 2 * u**3), atol=1e-9)


def test_trim_keeps_the_span_of_the_motion() -> None:
    landmarks, rate = walker(3.0)
    config = RetargetConfig(balance=replace(RetargetConfig().balance, passes=0))
    whole, _ = retarget(landmarks, rate, ironcub(), config)
    part, _ = retarget(landmarks, rate, ironcub(), config, span=(1.0, 2.0))
    assert len(part.time) == round(rate) + 1 and part.time[0] == 0.0
    assert part.metadata.metrics["source_span_s"] == [1.0, 2.0]
    middle = len(part.time) // 2  # the human's frame at 1.5 s (away from the filter's edges)
    np.testing.assert_allclose(
        part.landmarks[middle], whole.landmarks[round(rate) + middle], atol=2e-3
    )
    with pytest.raises(RetargetError, match="does not fit the motion"):
        retarget(landmarks, rate, ironcub(), config, span=(2.0, 3.5))
    with pytest.raises(RetargetError, match="trim '11_01'"):
        RetargetConfig(trim={"11_01": (2.0, 1.0)})
