"""iRonCub's left-right mirror: pairs by name, joint signs from the model's axes, mirroring
twice is the identity, MuJoCo steps a mirrored state to the mirror of the stepped state, and a
mirrored clip swaps the feet and keeps their heights."""

import mujoco
import numpy as np
import pytest

from motionkit.core.errors import RobotModelError
from motionkit.robot import ironcub
from motionkit.robot.mirror import Mirror, mirror_name, mirror_trajectory, partners, robot_mirror


@pytest.fixture(scope="module")
def robot():
    return ironcub()


@pytest.fixture(scope="module")
def mirror(robot) -> Mirror:
    return robot_mirror(robot)


def test_names_pair_by_their_side() -> None:
    assert mirror_name("l_hip_roll") == "r_hip_roll"
    assert mirror_name("chest_left") == "chest_right"
    assert mirror_name("r_arm_jet_turbine") == "l_arm_jet_turbine"
    assert mirror_name("torso_roll") == "torso_roll"
    assert mirror_name("lr_link") == "lr_link"  # a side is a whole part of the name
    assert partners(["a", "l_x", "r_x"], "joints").tolist() == [0, 2, 1]
    with pytest.raises(RobotModelError, match=r"no mirror for joints \['l_x'\].*\['r_x'\]"):
        partners(["l_x", "y"], "joints")


def test_ironcub_mirror_swaps_sides_and_flips_the_torsos_roll_and_yaw(robot, mirror) -> None:
    names = robot.joint_names
    for i, name in enumerate(names):
        assert names[mirror.joints[i]] == mirror_name(name)
    # the legs' and arms' axes are mirror images (iCub's symmetric convention): +q maps to +q;
    # the torso's roll and yaw axes lie in the sagittal plane or across it: they change sign
    flipped = {names[i] for i in np.flatnonzero(mirror.joint_signs < 0)}
    assert flipped == {"torso_roll", "torso_yaw"}
    jets = [jet.name for jet in robot.spec.jets]
    assert [jets[i] for i in mirror.jets] == ["chest_right", "chest_left", "arm_right", "arm_left"]
    assert mirror.feet.tolist() == [1, 0]
    # the plane holds the forward axis (-x of root_link) and z: the normal is +-y
    assert np.allclose(np.abs(mirror.normal), [0.0, 1.0, 0.0])


def test_mirroring_twice_is_the_identity(mirror) -> None:
    rng = np.random.default_rng(0)
    q = rng.normal(size=(5, 23))
    assert np.array_equal(mirror.joint_values(mirror.joint_values(q)), q)
    v = rng.normal(size=(5, 3))
    assert np.allclose(mirror.vector(mirror.vector(v)), v)
    assert np.allclose(mirror.axial(mirror.axial(v)), v)
    quat = rng.normal(size=(5, 4))
    assert np.allclose(mirror.quaternion(mirror.quaternion(quat)), quat)
    # by hand: y flips for a position; for an angular velocity x and z flip
    assert np.allclose(mirror.vector(np.array([1.0, 2.0, 3.0])), [1.0, -2.0, 3.0])
    assert np.allclose(mirror.axial(np.array([1.0, 2.0, 3.0])), [-1.0, 2.0, -3.0])


def _mirror_state(mirror: Mirror, qpos, qvel, ctrl, joints: int):
    return (
        np.concatenate(
            [mirror.vector(qpos[:3]), mirror.quaternion(qpos[3:7]), mirror.joint_values(qpos[7:])]
        ),
        np.concatenate(
            [mirror.vector(qvel[:3]), mirror.axial(qvel[3:6]), mirror.joint_values(qvel[6:])]
        ),
        np.concatenate([mirror.joint_values(ctrl[:joints]), ctrl[joints:][mirror.jets]]),
    )


def test_mujoco_steps_a_mirrored_state_to_the_mirror_of_the_stepped_state(robot, mirror) -> None:
    """A perturbed standing state with joint velocities, other PD targets and unequal thrust,
    stepped 0.12 s on the floor: its mirror steps to the mirror of where it went, within what
    the model's own asymmetry gives (the public Mk1_1 places the arm jets 2 cm apart across
    the plane: a symmetric standing start drifts 0.5 mm sideways in 0.4 s). The same map with
    the torso's signs left at +1 misses by tens of millimetres."""
    model = mujoco.MjModel.from_xml_string(robot.mjcf_text)
    joints = len(robot.joint_names)
    rng = np.random.default_rng(0)
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, 0)
    qpos = data.qpos.copy()
    qpos[7:] += rng.uniform(-0.1, 0.1, joints)
    qvel = rng.normal(0.0, 0.2, model.nv)
    targets = qpos[7:] + rng.uniform(-0.2, 0.2, joints)
    ctrl = np.concatenate([targets, rng.uniform(50.0, 150.0, model.nu - joints)])

    def stepped(qpos, qvel, ctrl):
        data = mujoco.MjData(model)
        data.qpos[:], data.qvel[:], data.ctrl[:] = qpos, qvel, ctrl
        for _ in range(60):
            mujoco.mj_step(model, data)
        return data.qpos.copy(), data.qvel.copy()

    def error(mirror: Mirror) -> float:
        after = stepped(qpos, qvel, ctrl)
        expected = _mirror_state(mirror, *after, ctrl, joints)[0]
        mirrored_after = stepped(*_mirror_state(mirror, qpos, qvel, ctrl, joints))[0]
        return float(np.abs(mirrored_after - expected).max())

    moved = np.abs(stepped(qpos, qvel, ctrl)[0] - qpos).max()
    assert moved > 0.1  # the state changed a lot in those 0.12 s
    assert error(mirror) < 0.002
    wrong = Mirror(
        mirror.normal, mirror.joints, np.ones(joints), mirror.jets, mirror.feet, mirror.effectors
    )
    assert error(wrong) > 0.02


def test_a_mirrored_clip_swaps_the_feet_and_keeps_their_heights(robot, mirror) -> None:
    from motionkit.dataset.synthetic import synthetic_trajectory
    from motionkit.train.priors import sole_heights

    clip = synthetic_trajectory(robot, seconds=2.0)  # a walk on a left turn
    mirrored = mirror_trajectory(clip, mirror)
    heights, mirrored_heights = sole_heights(clip, robot), sole_heights(mirrored, robot)
    assert np.abs(heights[:, 0] - heights[:, 1]).max() > 0.01  # the feet differ
    # to 0.5 mm: iCub's legs are mirror images to about 0.1 mm in the model (the same clip's
    # feet, swapped, differ by 0.13 mm at most); a wrong map moves a sole by centimetres
    assert np.abs(mirrored_heights - heights[:, ::-1]).max() < 5e-4
    assert np.array_equal(mirrored.contacts, clip.contacts[:, ::-1])
    assert np.allclose(mirrored.base_position[:, 1], -clip.base_position[:, 1])
