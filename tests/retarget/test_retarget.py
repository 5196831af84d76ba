"""The retargeter on a synthetic walker: clean contacts, limits, tracking; a valid clip."""

from pathlib import Path

import numpy as np
import pytest
from walker import SHANK, THIGH, walker

from motionkit.dataset import write
from motionkit.dataset.validate import validate_clip
from motionkit.errors import RetargetError
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
    assert m["foot_slide_p95_m_s"] <= 0.01  # the walker's own feet slide ~9 cm/s at contact edges
    assert m["penetration_max_m"] <= 0.002
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
    assert all(c.ok for c in checks), [c for c in checks if not c.ok]
    assert trajectory.metadata.generator == "retarget" and trajectory.metadata.kind == "walk"


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
    from motionkit.retarget.targets import low_pass

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
    folder = Path(__file__).resolve().parents[2] / "retarget"
    recipes = sorted(folder.glob("*.toml"))
    assert recipes, folder
    for recipe in recipes:
        config = RetargetConfig.from_toml(recipe)
        assert config.clips and config.kind == "walk"
