"""Unit checks of the trajopt model: jets, config, wrench, kinematics, derivative assembly."""

from __future__ import annotations

import casadi as cs
import numpy as np
import pytest

from motionkit.core.errors import TrajoptError
from motionkit.jet_ident.p250 import (
    P250_COEFFS,
    steady_throttle,
    steady_thrust,
    thrust_acceleration,
)
from motionkit.robot.model import ironcub
from motionkit.trajopt.config import TrajoptConfig
from motionkit.trajopt.dynamics import KnotBlocks, quaternion_step, wrench
from motionkit.trajopt.kinematics import RobotKinematics
from motionkit.trajopt.solve import Prepared


@pytest.fixture(scope="module")
def kinematics() -> RobotKinematics:
    return RobotKinematics(ironcub())


def standing_q(robot) -> np.ndarray:
    posture = robot.spec.posture_angles()
    return np.r_[0.0, 0.0, 0.6, 1.0, 0.0, 0.0, 0.0, [posture[n] for n in robot.joint_names]]


def test_p250_in_casadi_is_the_numeric_model() -> None:
    x = cs.SX.sym("x", 3)
    symbolic = cs.Function("tddot", [x], [thrust_acceleration(P250_COEFFS, x[0], x[1], x[2])])
    for point in [(16.0, 0.0, 0.0), (150.0, -40.0, 80.0), (222.0, 12.5, 100.0)]:
        value = float(symbolic(point))
        assert value == pytest.approx(thrust_acceleration(P250_COEFFS, *point), rel=1e-12)
    idle = float(steady_thrust(P250_COEFFS, 0.0))  # the 'stand' start: at rest at 0 %
    assert 10.0 <= idle <= 16.5 and abs(float(symbolic([idle, 0.0, 0.0]))) < 1e-9
    throttle = float(steady_throttle(P250_COEFFS, 110.0))
    assert float(symbolic([110.0, 0.0, throttle])) == pytest.approx(0.0, abs=1e-9)
    # more throttle accelerates the engine at a given state
    assert float(symbolic([100.0, 0.0, 80.0])) > 0 > float(symbolic([100.0, 0.0, 20.0]))


def test_config_rejects_unknown_keys_and_bad_values() -> None:
    with pytest.raises(TrajoptError, match="unknown keys"):
        TrajoptConfig.from_dict({"scenario": {"heigth": 2.0}})
    with pytest.raises(TrajoptError, match=r"\[scenario\]: 'name' should be one of"):
        TrajoptConfig.from_dict({"scenario": {"name": "moonwalk"}})
    with pytest.raises(TrajoptError, match="knots"):
        TrajoptConfig().with_scenario(knots=3)
    config = TrajoptConfig.from_dict({"scenario": {"target": [1, 2, 3]}})
    assert config.scenario.target == (1.0, 2.0, 3.0)
    assert TrajoptConfig.from_dict(config.to_dict()) == config


def test_wrench_by_hand() -> None:
    corners = np.zeros((3, 2))
    corners[:, 0] = [0.1, 0.0, 0.0]
    forces = np.zeros((3, 2))
    forces[:, 0] = [0.0, 0.0, 10.0]
    blocks = KnotBlocks(
        {
            "com": cs.DM.zeros(3),
            "corners": cs.DM(corners.ravel("F")),
            "forces": cs.DM(forces.ravel("F")),
            "thrust": cs.DM([50.0]),
        }
    )
    force, moment = wrench(blocks, cs.DM([0.0, 0.2, 0.0]), cs.DM([0.0, 0.0, 1.0]), 2)
    force, moment = cs.evalf(force).full().ravel(), cs.evalf(moment).full().ravel()
    np.testing.assert_allclose(force, [0.0, 0.0, 60.0])
    # (0.1, 0, 0) x (0, 0, 10) = (0, -1, 0); (0, 0.2, 0) x (0, 0, 50) = (10, 0, 0)
    np.testing.assert_allclose(moment, [10.0, -1.0, 0.0], atol=1e-12)


def test_quaternion_step_is_a_small_rotation_about_omega() -> None:
    omega, dt = np.array([0.0, 0.0, 2.0]), 0.01
    quat = np.array(quaternion_step(cs.DM([1.0, 0, 0, 0]), cs.DM(omega), dt)).ravel()
    assert np.linalg.norm(quat) == pytest.approx(1.0)
    assert 2 * np.arctan2(quat[3], quat[0]) == pytest.approx(2.0 * dt, rel=1e-4)


def test_linear_momentum_is_mass_times_com_velocity(kinematics: RobotKinematics) -> None:
    robot = kinematics.robot
    rng = np.random.default_rng(1)
    q = standing_q(robot)
    nu = np.r_[rng.normal(size=3), 0.0, 0.0, 0.0, rng.normal(size=len(robot.joint_names))]
    h = 1e-6
    direction = np.r_[nu[:3], 0.0, 0.0, 0.0, 0.0, nu[6:]]
    com_plus = kinematics.evaluate(q + h * direction)["com"]
    com_minus = kinematics.evaluate(q - h * direction)["com"]
    momentum = kinematics.evaluate(q, nu)["momentum"].ravel()
    np.testing.assert_allclose(
        momentum[:3] / kinematics.mass, ((com_plus - com_minus) / (2 * h)).ravel(), atol=1e-6
    )
    assert kinematics.mass == pytest.approx(robot.total_mass, rel=1e-9)


def test_thrust_directions_point_up_at_zero_angles(kinematics: RobotKinematics) -> None:
    q = np.r_[0.0, 0.0, 1.0, 1.0, 0.0, 0.0, 0.0, np.zeros(len(kinematics.robot.joint_names))]
    directions = kinematics.evaluate(q)["jet_dir"]
    np.testing.assert_allclose(directions[2], 1.0, atol=1e-6)


def test_assembled_derivatives_equal_casadi_ad() -> None:
    config = TrajoptConfig().with_scenario(knots=8)
    prepared = Prepared(ironcub(), config)
    nlp, derivatives = prepared.problem.nlp()
    x, p = nlp["x"], nlp["p"]
    f, g = prepared.problem.reference["f"], prepared.problem.reference["g"]
    params = prepared.problem.functions.parameters(1e-3)
    rng = np.random.default_rng(0)
    x0 = np.r_[prepared.guess.ravel(order="F"), 0.07] + 0.05 * rng.standard_normal(x.shape[0])
    lam = rng.standard_normal(g.shape[0])
    lagrangian = 0.7 * f + cs.dot(lam, g)
    reference = cs.Function("h", [x, p], [cs.triu(cs.hessian(lagrangian, x)[0])])(x0, params)
    hessian = derivatives["hess_lag"](x0, params, 0.7, lam)
    np.testing.assert_allclose(cs.densify(hessian).full(), cs.densify(reference).full(), atol=1e-9)
    jacobian = cs.Function("j", [x, p], [cs.jacobian(g, x)])(x0, params)
    np.testing.assert_allclose(
        cs.densify(derivatives["jac_g"](x0, params)[1]).full(), cs.densify(jacobian).full()
    )
    gradient = cs.Function("g", [x, p], [cs.gradient(f, x)])(x0, params)
    np.testing.assert_allclose(derivatives["grad_f"](x0, params)[1].full(), gradient.full())
    # the compiled value functions agree with the reference ones
    values = cs.Function("v", [x, p], [nlp["f"], nlp["g"], f, g])(x0, params)
    np.testing.assert_allclose(values[0].full(), values[2].full(), rtol=1e-12)
    np.testing.assert_allclose(values[1].full(), values[3].full(), rtol=1e-12, atol=1e-12)
