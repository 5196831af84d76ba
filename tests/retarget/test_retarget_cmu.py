"""The retargeter's acceptance figures on the real CMU clips of the offline sample."""

import pytest

from motionkit.mocap import load_mocap
from motionkit.recipes import sample_mocap
from motionkit.retarget.config import RetargetConfig
from motionkit.robot import ironcub

pytest.importorskip("placo")
from motionkit.retarget.core import retarget

CMU = sample_mocap()


@pytest.fixture(scope="module", params=["02_01.bvh", "11_01.amc", "35_01.amc"])
def metrics(request: pytest.FixtureRequest) -> dict:
    clip = load_mocap(CMU / request.param)
    trajectory, _ = retarget(clip.landmarks(), clip.rate, ironcub(), RetargetConfig())
    return trajectory.metadata.metrics


def test_feet_planted_within_limits(metrics: dict) -> None:
    assert metrics["foot_slide_p95_m_s"] <= 0.01
    assert 0.05 <= metrics["source_slide_p95_m_s"]  # the human's own feet slide far more
    assert metrics["penetration_max_m"] <= 0.002
    assert metrics["joint_position_violations"] == 0
    assert metrics["joint_velocity_violations"] == 0
    assert metrics["feet_error_mean_m"] <= 0.03


def test_tracking_and_clearance(metrics: dict) -> None:
    assert metrics["knees_error_mean_m"] <= 0.04 and metrics["elbows_error_mean_m"] <= 0.03
    assert 0.4 <= metrics["contact_share"] <= 0.8  # walking: single and double support
    assert metrics["closest_jet_or_arm_m"] >= 0.0  # self-collision avoidance keeps them apart
