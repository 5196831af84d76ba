"""The retargeted clips stay what they were: a short segment of a sample clip, retargeted with
the sample recipe (targets, IK, balance filter) and through the IK alone with settings that
engage its other branches (the ground guard, no self-collision or velocity limits), against
joint positions and base poses recorded when the IK came to solve each frame to convergence
(data/reference.npz; `python tests/retarget/test_retarget_reference.py` records it anew).

How close "the same" is: another CPU rounds differently (fused multiply-adds, vector widths,
the order PlaCo sums its tasks in, which follows their addresses). The IK solves every frame
until its step is below 1e-9 (rad, m), so rounding moves a frame's solution by about that and no
frame passes it on to the next. Rounding every PlaCo step at 1e-14 of its size (as another CPU
might) moved these outputs by at most 3e-9 (`test_rounding_does_not_move_the_motion`); the IK
that took two steps a frame left each frame 1e-3 rad short of its solution, and the same rounding
moved it by 1.4e-3 rad (3 mrad between two machines). TOLERANCE, 1e-6 rad or m, allows 300 times
that spread and stays 1,000 times below a milliradian or a millimetre, the least change of a
joint or the base that a clip's use (a policy's reference motion) could tell."""

from pathlib import Path

import numpy as np
import pytest

from motionkit import recipes
from motionkit.mocap import load_mocap
from motionkit.recipes import sample_mocap
from motionkit.retarget.config import RetargetConfig, Weights
from motionkit.robot import ironcub

REFERENCE = Path(__file__).parent / "data" / "reference.npz"
TOLERANCE = 1e-6  # rad (joints, quaternion components) or m (base positions): see above
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
        solved = solve_motion(robot, targets, points, config)
        out[f"{name}_base"], out[f"{name}_joints"] = solved.base, solved.joints
    return out


def test_retargeting_reproduces_the_reference() -> None:
    pytest.importorskip("placo")
    reference = np.load(REFERENCE)
    now = outputs()
    assert sorted(now) == sorted(reference.files)
    for name, values in now.items():
        np.testing.assert_allclose(values, reference[name], rtol=0, atol=TOLERANCE, err_msg=name)


def test_rounding_does_not_move_the_motion(monkeypatch: pytest.MonkeyPatch) -> None:
    """Every PlaCo step scaled by 1 + 1e-14 noise (a stand-in for another CPU's rounding): the
    converged motion stays within 1e-8 rad and m of the plain one, every frame converged."""
    placo = pytest.importorskip("placo")
    from motionkit.retarget.core import trimmed
    from motionkit.retarget.ik import solve_motion
    from motionkit.retarget.points import robot_points
    from motionkit.retarget.targets import RobotGeometry, make_targets

    robot, human, config = ironcub(), load_mocap(sample_mocap() / CLIP), RetargetConfig()
    points = robot_points(robot, config.points)
    geometry = RobotGeometry(robot, points, config.points.torso_frame)
    landmarks = trimmed(human.landmarks(), human.rate, SPAN)
    targets = make_targets(landmarks, human.rate, geometry, config)
    plain = solve_motion(robot, targets, points, config)
    rng = np.random.default_rng(0)

    class Rounding(placo.KinematicsSolver):
        def solve(self, apply: bool) -> np.ndarray:
            assert not apply  # the IK applies the steps itself
            step = super().solve(False)
            return step * (1.0 + 1e-14 * rng.standard_normal(step.shape))

    monkeypatch.setattr(placo, "KinematicsSolver", Rounding)
    rounded = solve_motion(robot, targets, points, config)
    assert plain.converged.all() and rounded.converged.all()
    assert np.abs(rounded.joints - plain.joints).max() < 1e-8
    assert np.abs(rounded.base - plain.base).max() < 1e-8


if __name__ == "__main__":
    np.savez_compressed(REFERENCE, **outputs())
