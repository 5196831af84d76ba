"""The MJCF export in MuJoCo against pinocchio on the URDF export, and simple physics checks."""

import numpy as np
import pytest

from motionkit.robot import THRUST_AXIS, ironcub

mujoco = pytest.importorskip("mujoco")
pin = pytest.importorskip("pinocchio")
GRAVITY = 9.81


@pytest.fixture(scope="module")
def mj():
    model = mujoco.MjModel.from_xml_path(str(ironcub().mjcf_path()))
    return model, mujoco.MjData(model)


@pytest.fixture(scope="module")
def pinocchio_model():
    return pin.buildModelFromUrdf(str(ironcub().urdf_path()), pin.JointModelFreeFlyer())


def random_states(count: int, seed: int):
    robot = ironcub()
    rng = np.random.default_rng(seed)
    for _ in range(count):
        quat = rng.normal(size=4)
        yield (
            rng.normal(size=3),
            quat / np.linalg.norm(quat),
            rng.uniform(robot.limits.lower, robot.limits.upper),
        )


def pinocchio_poses(model, position, quat_wxyz, joints):
    data = model.createData()
    q = pin.neutral(model)
    q[:3], q[3:7] = position, [*quat_wxyz[1:], quat_wxyz[0]]  # pinocchio: (x, y, z, w)
    for name, value in zip(ironcub().joint_names, joints, strict=True):
        q[model.joints[model.getJointId(name)].idx_q] = value
    pin.framesForwardKinematics(model, data, q)
    return data


def test_joint_order_and_mass_match(mj) -> None:
    model, _ = mj
    names = [model.joint(i).name for i in range(1, model.njnt)]
    assert tuple(names) == ironcub().joint_names
    assert [model.actuator(i).name for i in range(23)] == names
    assert model.body_mass.sum() == pytest.approx(ironcub().total_mass, abs=1e-9)
    assert model.nu == 23 + 4


def test_every_frame_matches_pinocchio(mj, pinocchio_model) -> None:
    model, data = mj
    for position, quat, joints in random_states(10, seed=1):
        data.qpos[:] = np.r_[position, quat, joints]
        mujoco.mj_kinematics(model, data)
        pdata = pinocchio_poses(pinocchio_model, position, quat, joints)
        for link in ironcub().model.links:
            expected = pdata.oMf[pinocchio_model.getFrameId(link)]
            np.testing.assert_allclose(data.site(link).xpos, expected.translation, atol=1e-6)
            np.testing.assert_allclose(
                data.site(link).xmat.reshape(3, 3), expected.rotation, atol=1e-6
            )


def test_jet_actuators_push_along_minus_z_of_the_jet_frame(mj, pinocchio_model) -> None:
    model, data = mj
    thrust = 100.0
    for position, quat, joints in random_states(3, seed=2):
        pdata = pinocchio_poses(pinocchio_model, position, quat, joints)
        for k, jet in enumerate(ironcub().spec.jets):
            data.qpos[:] = np.r_[position, quat, joints]
            data.ctrl[:] = 0
            data.ctrl[23 + k] = thrust
            mujoco.mj_forward(model, data)
            # The free joint's first three generalised forces are the net world force.
            rotation = pdata.oMf[pinocchio_model.getFrameId(jet.frame)].rotation
            np.testing.assert_allclose(
                data.qfrc_actuator[:3], thrust * rotation @ THRUST_AXIS, atol=1e-9
            )


def test_standing_under_pd_settles(mj) -> None:
    model, data = mj
    mujoco.mj_resetDataKeyframe(model, data, model.key("stand").id)
    start = data.qpos.copy()
    speeds = []
    for step in range(int(2.0 / model.opt.timestep)):
        mujoco.mj_step(model, data)
        if step * model.opt.timestep > 1.9:
            speeds.append(np.abs(data.qvel).max())
    assert np.all(np.isfinite(data.qpos))
    assert abs(data.qpos[2] - start[2]) < 0.02  # base height [m]
    tilt = 2 * np.degrees(np.arccos(min(1.0, abs(data.qpos[3]))))
    assert tilt < 5.0
    assert max(speeds) < 0.2  # settled [rad/s, m/s]
    assert data.ncon >= 8  # both soles flat: four corners each


def test_thrust_of_1_2_weights_lifts_with_0_2_g(mj) -> None:
    model, data = mj
    model = model.__copy__()
    for elbow in ("l_elbow", "r_elbow"):  # hold the arms at zero, just below the elbow limit
        model.jnt_range[model.joint(elbow).id, 0] = -0.1
        model.actuator_ctrlrange[model.actuator(elbow).id, 0] = -0.1
    data = mujoco.MjData(model)
    data.qpos[2] = model.key("stand").qpos[2] + 0.04  # straight legs: feet 4 cm above the floor
    data.qpos[3] = 1.0
    weight = model.body_mass.sum() * GRAVITY
    data.ctrl[23:] = 1.2 * weight / 4
    dt = model.opt.timestep
    heights = []
    # Over the first 0.1 s the arms have not yet bent under their jets' thrust.
    for _ in range(int(0.1 / dt)):
        mujoco.mj_step(model, data)
        heights.append(data.subtree_com[model.body("root_link").id][2])
    times = dt * np.arange(1, len(heights) + 1)
    acceleration = 2 * np.polyfit(times, heights, 2)[0]
    assert acceleration == pytest.approx((1.2 - 1.0) * GRAVITY, rel=0.01)
    start = data.qpos[2]
    for _ in range(int(0.4 / dt)):
        mujoco.mj_step(model, data)
    assert data.qpos[2] - start > 0.1  # about 0.5 a t^2 = 0.19 m in 0.4 s


def test_sole_boxes_match_the_sole_rectangles(mj) -> None:
    model, data = mj
    mujoco.mj_resetDataKeyframe(model, data, model.key("stand").id)
    mujoco.mj_forward(model, data)
    for side in ("left", "right"):
        length, width, height = 2 * model.geom(f"{side}_sole").size
        assert length == pytest.approx(0.126, abs=3e-3)  # reference: 0.126 m x 0.059 m
        assert width == pytest.approx(0.059, abs=2e-3)
        assert data.geom(f"{side}_sole").xpos[2] == pytest.approx(
            height / 2, abs=1e-4
        )  # on the floor
