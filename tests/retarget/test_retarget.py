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
