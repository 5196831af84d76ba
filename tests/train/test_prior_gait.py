"""The gait figures of a prior, by the evaluation's rules (a foot is down within 5 cm of the
ground), on a clip built by hand: two seconds at 30 Hz, the left foot lifted for the middle
20 of its 60 frames."""

from dataclasses import replace

import numpy as np
import pytest

from motionkit.dataset.synthetic import synthetic_trajectory
from motionkit.train.priors import gait_figures, sole_heights

STRAIGHT = 0.619438  # m: the soles below the base with every joint at zero


def test_gait_figures_count_frames_on_one_foot_and_switches(robot) -> None:
    clip = synthetic_trajectory(robot, 2.0, 30.0, seed=1)
    frames, names = clip.frames, list(robot.joint_names)
    joints = np.zeros((frames, len(names)))
    joints[20:40, names.index("l_hip_pitch")] = 0.8  # the left knee up: its sole 9.1 cm up
    joints[20:40, names.index("l_knee")] = -1.2
    clip = replace(
        clip,
        base_position=np.tile([0.0, 0.0, STRAIGHT], (frames, 1)),
        base_orientation=np.tile([1.0, 0.0, 0.0, 0.0], (frames, 1)),
        joint_positions=joints,
    )
    heights = sole_heights(clip, robot)
    np.testing.assert_allclose(heights[:20], 0.0, atol=1e-5)
    np.testing.assert_allclose(heights[20:40, 1], 0.0, atol=1e-5)
    assert heights[20:40, 0] == pytest.approx(np.full(20, 0.0915), abs=1e-3)
    figures = gait_figures([heights], 30.0)
    assert figures["single_support_share"] == pytest.approx(20 / 60)
    # the left sole lifts and lands: 2 switches over 59 steps of 2 feet, at 30 steps a second
    assert figures["contact_switches_per_second"] == pytest.approx(2 / 118 * 30)
    assert figures["sole_clearance_max_m"] == pytest.approx(0.0915, abs=1e-3)
    # two clips: the counts add up (no switch between the clips)
    both = gait_figures([heights, heights[:20]], 30.0)
    assert both["single_support_share"] == pytest.approx(20 / 80)
    assert both["contact_switches_per_second"] == pytest.approx(2 / (118 + 38) * 30)
