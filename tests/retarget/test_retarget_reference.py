"""The retargeted clips stay what they were: a short segment of a sample clip, retargeted with
the sample recipe (targets, IK, balance filter) and through the IK alone with settings that
engage its other branches (the ground guard, no self-collision or velocity limits), against
joint positions and base poses recorded before the IK was rewritten as tasks
(data/reference.npz; `python tests/retarget/test_retarget_reference.py` records it anew)."""

from pathlib import Path

import numpy as np
import pytest

from motionkit import recipes
from motionkit.mocap import load_mocap
from motionkit.recipes import sample_mocap
from motionkit.retarget.config import RetargetConfig, Weights
from motionkit.robot import ironcub

REFERENCE = Path(__file__).parent / "data" / "reference.npz"
CLIP, SPAN = "02_01.bvh", (0.0, 1.0)  # s: 121 frames, two touchdowns
# feet that give way to the pelvis: the soles sink below the ground, which the guard holds up
WEAK_FEET = Weights(
    foot_position=10.0,
    foot_orientation=1.0,
    contact_foot_position=100.0,
    contact_foot_orientation=10.0,
    pelvis_position=1000.0,
)
CONFIGS = {
    "ground_guard": RetargetConfig(weights=WEAK_FEET),
    "plain": RetargetConfig(self_collisions=False, velocity_limits=False, settle_iterations=5),
}


def outputs() -> dict[str, np.ndarray]:
    """The arrays that the reference holds, from the code as it is."""
    from motionkit.retarget.core import retarget, trimmed
    from motionkit.retarget.ik import solve_motion
    from motionkit.retarget.points import robot_points
    from motionkit.retarget.targets import RobotGeometry, make_targets

    robot, human = ironcub(), load_mocap(sample_mocap() / CLIP)
    recipe = RetargetConfig.from_toml(recipes.find("retarget", "sample_walks"))
    ticks: list[int] = []
    clip, _ = retarget(human.landmarks(), human.rate, robot, recipe, None, ticks.append, SPAN)
    out = {
        "recipe_joints": clip.joint_positions,
        "recipe_base_position": clip.base_position,
        "recipe_base_orientation": clip.base_orientation,
        "recipe_ticks": np.array(ticks),
    }
    landmarks = trimmed(human.landmarks(), human.rate, SPAN)
    for name, config in CONFIGS.items():
        points = robot_points(robot, config.points)
        geometry = RobotGeometry(robot, points, config.points.torso_frame)
        targets = make_targets(landmarks, human.rate, geometry, config)
        out[f"{name}_base"], out[f"{name}_joints"] = solve_motion(robot, targets, points, config)
    return out


def test_retargeting_reproduces_the_reference() -> None:
    pytest.importorskip("placo")
    reference = np.load(REFERENCE)
    now = outputs()
    assert sorted(now) == sorted(reference.files)
    for name, values in now.items():
        np.testing.assert_allclose(values, reference[name], rtol=0, atol=1e-9, err_msg=name)


if __name__ == "__main__":
    np.savez_compressed(REFERENCE, **outputs())
