"""Scenarios: boundary conditions, waypoints and the initial guess of a problem.

start 'stand': the spec's standing posture on the floor at the origin, at rest, jets at idle.
start 'hover': CoM at `start_position`, at rest and in equilibrium (knots 0 and 1 at rest), with
posture and thrust left to the solver. end 'hover' / 'stand': the same at the last two knots,
with the CoM at `target` (x, y only for 'stand', all corners on the floor).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from motionkit.core.errors import TrajoptError
from motionkit.jet_ident.p250 import P250_COEFFS, steady_throttle, steady_thrust
from motionkit.trajopt.kinematics import GRAVITY
from motionkit.trajopt.problem import Problem

AT_REST = ("com_velocity", "angular_momentum", "thrust_rate", "base_velocity")
AT_REST += ("base_angular_velocity", "joint_velocities")


@dataclass(frozen=True)
class Standing:
    q: np.ndarray  # configuration standing on the floor at the origin
    com: np.ndarray
    corners: np.ndarray  # 3 x C


def standing(problem: Problem) -> Standing:
    """The spec posture with the lowest sole corner on the floor."""
    fn = problem.functions
    q = np.zeros(fn.layout.joints + 7)
    q[3] = 1.0
    q[7:] = fn.posture
    out = fn.kinematics.evaluate(q)
    q[2] = -out["corners"][2].min()
    out = fn.kinematics.evaluate(q)
    return Standing(q, out["com"].ravel(), out["corners"])


def _rest(problem: Problem, knots: list[int]) -> None:
    lay = problem.layout
    for knot in knots:
        for block in AT_REST:
            problem.fix(knot, block, np.zeros(lay.blocks[block].size))


def apply_scenario(problem: Problem) -> tuple[np.ndarray, float]:
    """Add the scenario's bounds and constraints; return the initial guess (scaled W, dt)."""
    config, lay, n = problem.config, problem.layout, problem.knots
    scenario = config.scenario
    robot = problem.functions.kinematics.robot
    lift = sum(jet.t_max for jet in robot.spec.jets) * scenario.thrust_fraction
    if "hover" in (scenario.start, scenario.end) and lift < lay.mass * GRAVITY:
        raise TrajoptError(
            f"{robot.name} cannot hover: its jets lift at most {lift:.0f} N (t_max of the spec "
            f"x scenario.thrust_fraction), its weight is {lay.mass * GRAVITY:.0f} N"
        )
    stand = standing(problem)
    forward = np.array(robot.spec.forward)
    idle = float(steady_thrust(P250_COEFFS, 0.0))
    last = n - 1

    if scenario.start == "stand":
        problem.fix(0, "base_position", stand.q[:3])
        problem.fix(0, "base_quaternion", stand.q[3:7])
        problem.fix(0, "joints", stand.q[7:])
        problem.fix(0, "com", stand.com)
        problem.fix(0, "thrust", np.full(lay.jets, idle))
        _rest(problem, [0])
        start_com = stand.com
    else:
        start_com = np.array(scenario.start_position)
        problem.fix(0, "com", start_com)
        _rest(problem, [0, 1])
    target = np.array(scenario.target)
    _rest(problem, [last - 1, last])
    if scenario.end == "hover":
        problem.fix(last, "com", target)
        end_com = target
    else:
        problem.bound(last, "com", [*target[:2], -np.inf], [*target[:2], np.inf])
        problem.bound_corners(last, range(lay.corners), 2, 0.0, 0.0)
        end_com = np.array([*target[:2], stand.com[2]])

    per_foot = lay.corners // 2
    if scenario.step_foot:
        foot = 0 if scenario.step_foot == "left" else 1
        corners = range(foot * per_foot, (foot + 1) * per_foot)
        land = round(scenario.step_land * last)
        goal = stand.corners[:, corners] + scenario.step_length * forward[:, None]
        for axis in range(2):
            problem.bound_corners(land, corners, axis, goal[axis], goal[axis])
        problem.bound_corners(land, corners, 2, 0.0, 0.0)
        problem.bound_corners(land // 2, corners, 2, scenario.step_clearance, np.inf)
    if scenario.apex_clearance > 0:
        apex = round(scenario.apex_at * last)
        problem.bound_corners(apex, range(lay.corners), 2, scenario.apex_clearance, np.inf)

    return _guess(problem, stand, start_com, end_com, idle)


def _guess(
    problem: Problem, stand: Standing, start_com: np.ndarray, end_com: np.ndarray, idle: float
) -> tuple[np.ndarray, float]:
    """Straight-line (smoothstep) motion of the standing pose from start to end, thrust that
    carries the weight where the guessed feet are off the floor, weight on the corners where not."""
    config, lay, n = problem.config, problem.layout, problem.knots
    scenario = config.scenario
    low, high = problem.dt_bounds()
    dt = 0.5 * (low + high)
    tau = np.linspace(0.0, 1.0, n)
    blend = 3 * tau**2 - 2 * tau**3
    com = start_com[:, None] + (end_com - start_com)[:, None] * blend
    if scenario.apex_clearance > 0:
        bump = np.clip(1 - np.abs(tau - scenario.apex_at) / 0.25, 0, 1)
        com[2] += 1.5 * scenario.apex_clearance * bump
    base = stand.q[:3, None] + com - stand.com[:, None]
    height = stand.corners[2].min() + base[2] - stand.q[2]  # lowest corner above the floor
    airborne = height > 0.005
    mass = lay.mass
    weight = mass * GRAVITY
    t_max = min(jet.t_max for jet in problem.functions.kinematics.robot.spec.jets)
    hover = min(weight / lay.jets, t_max * scenario.thrust_fraction)
    thrust = np.where(airborne, hover, idle)

    physical = {name: np.zeros((b.size, n)) for name, b in lay.blocks.items()}
    physical["base_position"] = base
    physical["base_quaternion"][0] = 1.0
    physical["joints"][:] = stand.q[7:, None]
    physical["com"] = com
    velocity = np.gradient(com, dt, axis=1)
    physical["com_velocity"] = velocity
    physical["base_velocity"] = velocity
    physical["corners"] = np.repeat(stand.corners.T.reshape(-1, 1), n, axis=1)
    physical["corners"] += np.tile(base - stand.q[:3, None], (lay.corners, 1))
    physical["thrust"][:] = thrust
    physical["throttle"][:] = steady_throttle(P250_COEFFS, thrust)
    on_floor = ~airborne
    physical["forces"][2::3] = np.where(on_floor, (weight - lay.jets * thrust) / lay.corners, 0.0)
    physical["forces"][2::3] = np.maximum(physical["forces"][2::3], 0.0)
    physical["net_force"][2] = physical["forces"][2::3].sum(axis=0) + lay.jets * thrust
    guess = np.vstack([physical[name] / b.scale for name, b in lay.blocks.items()])
    return guess, dt
