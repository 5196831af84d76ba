"""Scenarios: boundary conditions, waypoints and the initial guess of a problem.

start 'stand': the spec's standing posture on the floor at the origin, at rest, jets at idle.
start 'hover': CoM at `start_position`, at rest and in equilibrium (knots 0 and 1 at rest), with
posture and thrust left to the solver. end 'hover' / 'stand': the same at the last two knots,
with the CoM at `target` (x, y only for 'stand', every sole flat on the floor).

Every boundary condition is imposed once, on independent quantities: a knot at rest fixes its
velocities (base and joints) and thrust rate, and its CoM velocity and angular momentum follow
from them by the kinematic ties; a foot is put flat on the floor by three of its corners (the
plane of its sole), placed by one corner's x, y and one coordinate of another; and a corner
whose height the fixed configuration already sets carries no floor bound. A condition imposed
twice (the eight corners of a fixed standing pose bounded by the floor as well, four corners of
a rigid sole all set to z = 0) makes the active constraints linearly dependent: their
multipliers are then not unique, IPOPT let them grow to 1e4-1e5 while the slack of the implied
bounds shrank to rounding noise, and the solves crawled and stalled (a jump at a dual
infeasibility of 2.4e-5 after 500 iterations), their paths set by the CPU's rounding.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from motionkit.core.errors import TrajoptError
from motionkit.jet_ident.p250 import P250_COEFFS, steady_throttle, steady_thrust
from motionkit.trajopt.kinematics import GRAVITY
from motionkit.trajopt.problem import Problem

# what a knot at rest fixes to zero (its CoM velocity and angular momentum follow by the ties)
AT_REST = ("base_velocity", "base_angular_velocity", "joint_velocities", "thrust_rate")


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


def foot_corners(problem: Problem) -> list[list[int]]:
    """The corner indices of each foot, in the knots' corner order."""
    start, feet = 0, []
    for foot in problem.functions.kinematics.robot.spec.feet:
        feet.append(list(range(start, start + len(foot.corners))))
        start += len(foot.corners)
    return feet


def sole_support(points: np.ndarray) -> list[int]:
    """At most three of a sole's corners (`points`: 3 x C, the standing positions) that fix
    its plane: the three spanning the largest triangle in x, y (all of them when there are
    fewer than four). The others lie in that plane on a rigid sole: bounding them too would
    repeat a condition."""
    count = points.shape[1]
    if count < 4:
        return list(range(count))

    def area(trio: tuple[int, int, int]) -> float:
        (ax, ay), (bx, by), (cx, cy) = (points[:2, i] for i in trio)
        return abs((bx - ax) * (cy - ay) - (by - ay) * (cx - ax))

    trios = [
        (i, j, k) for i in range(count) for j in range(i + 1, count) for k in range(j + 1, count)
    ]
    return list(max(trios, key=area))


def flat_on_floor(problem: Problem, knot: int, corners: list[int], standing: np.ndarray) -> None:
    """The sole of `corners` flat on the floor at `knot`: three of them at z = 0, the others'
    floor bound lifted (they are on the floor by the sole's rigidity)."""
    support = [corners[i] for i in sole_support(standing[:, corners])]
    problem.bound_corners(knot, support, 2, 0.0, 0.0)
    free = [c for c in corners if c not in support]
    problem.bound_corners(knot, free, 2, -np.inf, np.inf)


def place_foot(
    problem: Problem, knot: int, corners: list[int], standing: np.ndarray, goal: np.ndarray
) -> None:
    """The foot of `corners` flat on the floor at `knot` with its corners at `goal` (3 x C, a
    translation of `standing`): one corner's x and y, and the one coordinate of a second
    corner that turns with the foot's yaw fix its place on the floor."""
    flat_on_floor(problem, knot, corners, standing)
    support = sole_support(standing[:, corners])
    if len(support) < 2:
        problem.bound_corners(knot, [corners[support[0]]], 0, goal[0, 0], goal[0, 0])
        problem.bound_corners(knot, [corners[support[0]]], 1, goal[1, 0], goal[1, 0])
        return
    pairs = [(a, b) for a in support for b in support if a < b]
    a, b = max(pairs, key=lambda ab: float(np.linalg.norm(goal[:2, ab[1]] - goal[:2, ab[0]])))
    for axis in range(2):
        problem.bound_corners(knot, [corners[a]], axis, goal[axis, a], goal[axis, a])
    dx, dy = goal[:2, b] - goal[:2, a]
    axis = 1 if abs(dx) >= abs(dy) else 0  # the coordinate a yaw about corner a moves most
    problem.bound_corners(knot, [corners[b]], axis, goal[axis, b], goal[axis, b])


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

    feet = foot_corners(problem)
    if scenario.start == "stand":
        problem.fix(0, "base_position", stand.q[:3])
        problem.fix(0, "base_quaternion", stand.q[3:7])
        problem.fix(0, "joints", stand.q[7:])
        problem.fix(0, "thrust", np.full(lay.jets, idle))
        _rest(problem, [0])
        # knot 0's configuration is fixed and knot 1's equals it (knot 0 at rest): their CoM
        # and corners follow by the ties, so the corners carry no floor bound as well
        for knot in (0, 1):
            problem.bound_corners(knot, range(lay.corners), 2, -np.inf, np.inf)
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
        for corners in feet:
            flat_on_floor(problem, last, corners, stand.corners)
        # the knot before has the last one's configuration (at rest): on the floor already
        problem.bound_corners(last - 1, range(lay.corners), 2, -np.inf, np.inf)
        end_com = np.array([*target[:2], stand.com[2]])

    if scenario.step_foot:
        corners = feet[0 if scenario.step_foot == "left" else 1]
        land = round(scenario.step_land * last)
        goal = stand.corners[:, corners] + scenario.step_length * forward[:, None]
        place_foot(problem, land, corners, stand.corners, goal)
        problem.bound_corners(land // 2, corners, 2, scenario.step_clearance, np.inf)
    if scenario.apex_clearance > 0:
        apex = round(scenario.apex_at * last)
        problem.bound_corners(apex, range(lay.corners), 2, scenario.apex_clearance, np.inf)

    return _guess(problem, stand, start_com, end_com, idle)


def _guess(
    problem: Problem, stand: Standing, start_com: np.ndarray, end_com: np.ndarray, idle: float
) -> tuple[np.ndarray, float]:
    """Straight-line (smoothstep) motion of the standing pose from start to end, thrust that
    carries the weight where the guessed feet are off the floor, weight on the corners where
    not, at the longest time step allowed: the running costs (velocities, accelerations, rates)
    all fall with the time step, so an optimised one ends on its upper bound."""
    config, lay, n = problem.config, problem.layout, problem.knots
    scenario = config.scenario
    _, dt = problem.dt_bounds()
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
