"""The physics check against hand-worked cases on the toy biped (tests/conftest.py: joints about
y, link masses at their frame origins, sole 0.75 m below the pelvis in the zero pose)."""

import json
from pathlib import Path

import numpy as np
import pytest

from motionkit.core.errors import DatasetError
from motionkit.dataset import Metadata, Trajectory, write
from motionkit.dataset.physics import (
    GRAVITY,
    PhysicsConfig,
    _split,
    check_physics,
    nearest_in_polygon,
    polygon_distance,
)
from motionkit.dataset.validate import validate_clip

pytest.importorskip("pinocchio")

MASS = 11.0  # kg, the toy's links summed by hand
# CoM y: the arm and elbow (0.5 kg each) sit at y = 0.15, the rest is symmetric about y = 0
COM_Y = (0.5 * 0.15 + 0.5 * 0.15) / MASS


def still(robot, joints: dict[str, float], height: float, thrust: float = 0.0, frames: int = 5):
    """The robot held still (upright base at `height`) for a few frames."""
    count = len(robot.joint_names)
    angles = np.array([joints.get(name, 0.0) for name in robot.joint_names])
    zeros = np.zeros((frames, 3))
    return Trajectory(
        time=np.arange(frames) * 0.01,
        base_position=np.tile([0.0, 0.0, height], (frames, 1)),
        base_orientation=np.tile([1.0, 0.0, 0.0, 0.0], (frames, 1)),
        joint_names=robot.joint_names,
        joint_positions=np.tile(angles, (frames, 1)),
        joint_velocities=np.zeros((frames, count)),
        base_linear_velocity=zeros,
        base_angular_velocity=zeros,
        thrust=np.full((frames, len(robot.spec.jets)), thrust),
        contacts=np.ones((frames, 2), dtype=bool),
        jet_names=tuple(jet.name for jet in robot.spec.jets),
        foot_names=("left", "right"),
        metadata=Metadata(robot.name, robot.model_hash, "stand", "synthetic"),
    )


def test_standing_still_carries_the_weight_with_the_cop_under_the_com(toy_robot) -> None:
    report = check_physics(still(toy_robot, {}, height=0.75), toy_robot)
    assert report.weight == pytest.approx(MASS * GRAVITY)
    assert report.contacts.all()  # both feet flat on the floor
    np.testing.assert_allclose(report.cop, np.tile([0.0, COM_Y], (5, 1)), atol=1e-9)
    # double support: corners x in [-0.05, 0.1], y in [-0.14, 0.14]; nearest edge x = -0.05
    np.testing.assert_allclose(report.support_distance, 0.05, atol=1e-9)
    assert report.residual_force.max() < 1e-3 * report.weight
    np.testing.assert_allclose(report.friction_ratio, 0.0, atol=1e-9)  # no sideways force
    # every mass sits on the vertical through the joints' axes (x = 0) and so does the total
    # CoP: the ground's moment about the (common) ankle, knee and hip axes is zero, so each
    # pair of torques cancels (the split of the load between the feet is not unique)
    names = report.joint_names
    for joint in ("ankle", "knee", "hip"):
        pair = (
            report.torques[:, names.index(f"l_{joint}")]
            + report.torques[:, names.index(f"r_{joint}")]
        )
        np.testing.assert_allclose(pair, 0.0, atol=2e-3)  # the split's regularisation
    np.testing.assert_allclose(report.torques[:, names.index("shoulder")], 0.0, atol=1e-9)
    assert np.abs(report.torques).max() < 0.2
    figures = report.summary()
    assert figures["cop_inside_share"] == 1.0 and figures["torque_within_share"] == 1.0
    assert not report.warnings()


def test_single_support_cop_and_swing_leg_torques_by_hand(toy_robot) -> None:
    theta = -0.5  # right hip pitch: the right leg swings forward, its sole 5.7 cm up
    report = check_physics(still(toy_robot, {"r_hip": theta}, height=0.75), toy_robot)
    assert report.contacts[:, 0].all() and not report.contacts[:, 1].any()
    # held still, the ground wrench is the weight through the CoM: the CoP is its projection.
    # Shin (0.5 kg) and foot (0.5 kg) hang 0.3 and 0.6 m along the leg, at x = -L sin(theta).
    com_x = -(0.5 * 0.3 + 0.5 * 0.6) * np.sin(theta) / MASS
    np.testing.assert_allclose(report.cop, np.tile([com_x, COM_Y], (5, 1)), atol=1e-9)
    # the left sole spans y in [0.06, 0.14]: the CoP is outside by 0.06 - COM_Y
    np.testing.assert_allclose(report.support_distance, -(0.06 - COM_Y), atol=1e-9)
    assert not report.cop_inside.any() and report.residual_force.min() > 0
    # the swing leg's joints hold its own weight: tau = -g sum m x (x: lever from the axis)
    hip = report.joint_names.index("r_hip")
    knee = report.joint_names.index("r_knee")
    tau_hip = GRAVITY * (0.5 * 0.3 + 0.5 * 0.6) * np.sin(theta)
    tau_knee = GRAVITY * 0.5 * 0.3 * np.sin(theta)
    np.testing.assert_allclose(report.torques[:, hip], tau_hip, rtol=1e-9)
    np.testing.assert_allclose(report.torques[:, knee], tau_knee, rtol=1e-9)
    assert report.torques[:, report.joint_names.index("r_ankle")] == pytest.approx(0.0, abs=1e-9)


def test_hovering_on_thrust_leaves_the_hand_computed_residual(toy_robot) -> None:
    # both jets point up (frames turned by pi about x; thrust along -z of the jet frame)
    thrust = 0.5 * MASS * GRAVITY
    report = check_physics(still(toy_robot, {}, height=2.0, thrust=thrust), toy_robot)
    assert not report.contacts.any() and np.isnan(report.cop).all()
    assert report.residual_force.max() < 1e-6 * report.weight  # thrust carries it (float32)
    # jets at y = +-0.1, CoM at COM_Y: the thrust turns the robot about x by 2 T COM_Y
    np.testing.assert_allclose(report.residual_moment, 2 * thrust * COM_Y, rtol=1e-6)
    falling = check_physics(still(toy_robot, {}, height=2.0), toy_robot)
    np.testing.assert_allclose(falling.residual_force, MASS * GRAVITY, rtol=1e-9)


def test_inverse_dynamics_agree_with_the_com_acceleration_of_a_free_motion(toy_robot) -> None:
    """In the air without thrust, the unexplained force is m (c'' - g); c from our own
    kinematics (RobotModel.link_poses), not pinocchio, differentiated numerically."""
    time = np.linspace(0.0, 1.0, 1001)
    angles = 0.4 * np.sin(2 * np.pi * time[:, None] * np.arange(1, 8) / 4 + np.arange(7))
    position = np.stack([0.2 * np.sin(3 * time), 0.1 * time**2, 2 + 0.3 * np.cos(2 * time)], 1)
    yaw = 0.5 * time
    zeros = np.zeros_like(time)
    clip = Trajectory(
        time=time,
        base_position=position,
        base_orientation=np.stack([np.cos(yaw / 2), zeros, zeros, np.sin(yaw / 2)], 1),
        joint_names=toy_robot.joint_names,
        joint_positions=angles,
        joint_velocities=np.gradient(angles, time, axis=0),
        base_linear_velocity=np.gradient(position, time, axis=0),
        base_angular_velocity=np.stack([zeros, zeros, np.full_like(time, 0.5)], 1),
        thrust=np.zeros((len(time), 2)),
        contacts=np.zeros((len(time), 2), dtype=bool),
        jet_names=("a", "b"),
        foot_names=("left", "right"),
        metadata=Metadata(toy_robot.name, toy_robot.model_hash, "other", "synthetic"),
    )
    report = check_physics(clip, toy_robot, PhysicsConfig(smoothing_hz=0.0))
    model = toy_robot.model
    com = []
    for k in range(len(time)):
        poses = model.link_poses(dict(zip(toy_robot.joint_names, angles[k], strict=True)))
        total = sum(model.links[n].inertial.mass * poses[n][:3, 3] for n in poses
                    if model.links[n].inertial is not None)  # fmt: skip
        c, s = np.cos(yaw[k]), np.sin(yaw[k])
        com.append(position[k] + np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]]) @ (total / MASS))
    acceleration = np.gradient(np.gradient(np.array(com), time, axis=0), time, axis=0)
    expected = MASS * np.linalg.norm(acceleration + np.array([0.0, 0.0, GRAVITY]), axis=1)
    np.testing.assert_allclose(report.residual_force[5:-5], expected[5:-5], rtol=2e-3)


def test_polygon_distance_and_nearest_point_by_hand() -> None:
    square = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0], [0.5, 0.5]])
    assert polygon_distance(np.array([0.5, 0.25]), square) == pytest.approx(0.25)
    assert polygon_distance(np.array([2.0, 0.5]), square) == pytest.approx(-1.0)
    assert polygon_distance(np.array([2.0, 2.0]), square) == pytest.approx(-np.sqrt(2))
    segment = np.array([[0.0, 0.0], [1.0, 0.0]])
    assert polygon_distance(np.array([0.5, 0.3]), segment) == pytest.approx(-0.3)
    np.testing.assert_allclose(nearest_in_polygon(np.array([2.0, 0.5]), square), [1.0, 0.5])
    # shrunk by 0.1 towards the centre (inradius 0.5: scaled by 0.8 about (0.5, 0.5))
    np.testing.assert_allclose(nearest_in_polygon(np.array([2.0, 0.5]), square, 0.1), [0.9, 0.5])
    np.testing.assert_allclose(nearest_in_polygon(np.array([0.5, 0.4]), square, 0.1), [0.5, 0.4])


def test_bad_configs_and_clips_are_refused(toy_robot, tmp_path: Path) -> None:
    with pytest.raises(DatasetError, match="friction"):
        PhysicsConfig(friction=-1.0)
    with pytest.raises(DatasetError, match="share"):
        PhysicsConfig(min_cop_inside_share=1.5)
    with pytest.raises(DatasetError, match="differences"):
        PhysicsConfig(differences="backward")
    recipe = tmp_path / "physics.toml"
    recipe.write_text("fricton = 0.5\n")
    with pytest.raises(DatasetError, match="unknown keys"):
        PhysicsConfig.from_toml(recipe)
    recipe.write_text("smoothing_hz = nan\n")
    with pytest.raises(DatasetError, match="smoothing_hz"):
        PhysicsConfig.from_toml(recipe)
    clip = still(toy_robot, {}, height=0.75)
    bad = Trajectory(**{**clip.__dict__, "thrust": np.full((5, 2), np.nan)})
    with pytest.raises(DatasetError, match="thrust is not finite"):
        check_physics(bad, toy_robot)


def test_validate_warns_and_check_physics_reports(
    toy_robot_files, tmp_path: Path, capsys: pytest.CaptureFixture
) -> None:
    from motionkit.cli import main
    from motionkit.robot import load_robot

    urdf, spec = toy_robot_files
    robot = load_robot(urdf, spec)
    write(tmp_path / "stand.mcap", still(robot, {}, height=0.75), robot)
    write(tmp_path / "swing.mcap", still(robot, {"r_hip": -0.5}, height=0.75), robot)
    checks = validate_clip(tmp_path / "swing.mcap", robot)
    physics = checks[-1]
    assert physics.warning and not physics.ok and "cop_inside_share = 0.000" in physics.detail
    assert all(c.ok for c in checks[:-1])
    robot_args = ["--urdf", str(urdf), "--spec", str(spec)]
    assert main(["dataset", "validate", str(tmp_path), *robot_args]) == 0  # a warning only
    assert "[WARN] physics" in capsys.readouterr().out
    code = main(["dataset", "check-physics", str(tmp_path), "--json", *robot_args])
    assert code == 1  # the swinging clip falls short
    report = json.loads(capsys.readouterr().out)
    by_name = {Path(row["path"]).stem: row for row in report["clips"]}
    assert by_name["stand"]["cop_inside_share"] == 1.0 and not by_name["stand"]["warnings"]
    assert by_name["swing"]["cop_inside_share"] == 0.0 and by_name["swing"]["warnings"]
    assert report["config"]["friction"] == PhysicsConfig().friction


def test_a_sliding_corner_pushes_with_kinetic_friction_only() -> None:
    """One corner at the base origin (J^T: the force itself, no moment) must carry a weight W.
    Still, it pushes straight up; sliding along x, only along (-mu, 0, 1): the least-squares
    force is W / (1 + mu^2) of that direction."""
    config, weight = PhysicsConfig(), 400.0
    transpose = np.zeros((9, 3))
    transpose[:3] = np.eye(3)
    wrench = np.array([0.0, 0.0, weight, 0.0, 0.0, 0.0])
    loaded = [(np.zeros(3), transpose)]
    still_force = _split(wrench, loaded, [np.zeros(2)], config, weight)
    np.testing.assert_allclose(still_force, [[0.0, 0.0, weight]], rtol=1e-3, atol=1e-9)
    slide = _split(wrench, loaded, [np.array([0.5, 0.0])], config, weight)
    mu = config.friction
    np.testing.assert_allclose(slide, [[-mu, 0.0, 1.0]] * np.array(weight / (1 + mu**2)), rtol=1e-3)
