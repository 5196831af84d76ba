"""The walk recipe on the real CMU clips of the offline sample: the retargeter's acceptance
figures, and a motion the robot can perform (physics check and open-loop tracking)."""

import pytest

from motionkit import recipes
from motionkit.dataset.tracking import track_windows
from motionkit.mocap import load_mocap
from motionkit.recipes import sample_mocap
from motionkit.retarget.config import RetargetConfig
from motionkit.robot import ironcub

pytest.importorskip("placo")
from motionkit.retarget.core import retarget

CMU = sample_mocap()
RECIPE = RetargetConfig.from_toml(recipes.find("retarget", "sample_walks"))


@pytest.fixture(scope="module", params=["02_01.bvh", "11_01.amc", "35_01.amc"])
def clip(request: pytest.FixtureRequest):
    human = load_mocap(CMU / request.param)
    span = RECIPE.trim.get(human.name)
    trajectory, _ = retarget(human.landmarks(), human.rate, ironcub(), RECIPE, span=span)
    return trajectory


@pytest.fixture(scope="module")
def metrics(clip) -> dict:
    return clip.metadata.metrics


def test_feet_planted_within_limits(metrics: dict) -> None:
    assert metrics["foot_slide_p95_m_s"] <= 0.003  # the gate; hard contacts: about 1e-10
    assert 0.05 <= metrics["source_slide_p95_m_s"]  # the human's own feet slide far more
    assert metrics["penetration_max_m"] <= 0.001
    assert metrics["joint_position_violations"] == 0
    assert metrics["joint_velocity_violations"] == 0
    assert metrics["feet_error_mean_m"] <= 0.03


def test_tracking_and_clearance(metrics: dict) -> None:
    assert metrics["knees_error_mean_m"] <= 0.04 and metrics["elbows_error_mean_m"] <= 0.03
    assert 0.4 <= metrics["contact_share"] <= 0.8  # walking: single and double support
    assert metrics["closest_jet_or_arm_m"] >= 0.0  # self-collision avoidance keeps them apart


def test_the_robot_can_perform_it(clip, metrics: dict) -> None:
    physics = metrics["physics"]
    assert metrics["slowdown"] == 1.25
    assert physics["cop_inside_share_single_support"] >= 0.9
    assert physics["torque_within_share_single_support"] >= 0.9
    tracking = track_windows(clip, ironcub(), stride=0.25)
    assert tracking.fall_share <= 0.1  # without the filter and clearance: 0.50-0.58
