"""Checks of a solution: residuals, complementarity, target, thrust limits (metadata figures)."""

from __future__ import annotations

from typing import Any

import numpy as np

from motionkit.robot import Robot
from motionkit.trajopt.solve import Solution, violation

ON_GROUND = 1e-3  # m: a corner at most this high is on the floor
AIRBORNE = 0.05  # m: a knot is airborne when every sole corner is higher than this
TARGET_TOLERANCE = 0.01  # m
COMPLEMENTARITY_TOLERANCE = 1e-4  # N m, largest f_z c_z of any corner at any knot
THRUST_SLACK = 1e-3  # N


def check_solution(solution: Solution, robot: Robot) -> dict[str, Any]:
    """Figures that say whether the solution is physically consistent; `passed` sums them up.

    `passed`: every constraint group within 10 times the solver's constr_viol_tol,
    complementarity under 1e-4 N m, the target error within 1 cm and the thrusts within
    [0, t_max * thrust_fraction] (to 1 mN).

    Args:
        solution: the solved knots (`Prepared.solve`).
        robot: the robot it was solved for (its jets' thrust limits).

    Returns:
        The figures: the largest residual of each constraint group (kinematic ties,
        dynamics, contact, no-slip), complementarity_violation_nm (largest f_z c_z [N m]),
        max_force_off_ground_n, target_error_m (the last CoM's distance to the target; x, y
        only for a stand end), thrust_min_n, thrust_max_n, thrust_within_limits and passed.
    """
    knots, config = solution.knots, solution.config
    scenario = config.scenario
    worst = violation(solution.constraint_values, solution.lower, solution.upper)
    groups = {
        name: float(worst[rows].max(initial=0.0))
        for name, rows in solution.constraint_groups.items()
    }
    normal = knots["forces"][:, 2::3]
    heights = knots["corners"][:, 2::3]
    complementarity = float(np.max(np.maximum(normal, 0) * np.maximum(heights, 0)))
    off_ground = float(np.max(np.where(heights > ON_GROUND, normal, 0.0), initial=0.0))
    target = np.array(scenario.target)
    end = knots["com"][-1]
    error = end - target if scenario.end == "hover" else (end - target)[:2]
    t_max = np.array([jet.t_max for jet in robot.spec.jets]) * scenario.thrust_fraction
    thrust = knots["thrust"]
    # IPOPT relaxes bounds by 1e-8 of their scaled value (~1e-6 N here): limits hold to 1 mN
    thrust_ok = bool(np.all(thrust >= -THRUST_SLACK) and np.all(thrust <= t_max + THRUST_SLACK))
    tolerance = config.solver.constr_viol_tol
    figures: dict[str, Any] = {
        "residual_kinematic_ties": groups["kinematic ties"],
        "residual_dynamics": groups["dynamics defects"],
        "residual_contact": groups["contact"],
        "residual_no_slip": groups["no-slip"],
        "complementarity_violation_nm": complementarity,
        "max_force_off_ground_n": off_ground,
        "target_error_m": float(np.linalg.norm(error)),
        "thrust_min_n": float(thrust.min()),
        "thrust_max_n": float(thrust.max()),
        "thrust_within_limits": thrust_ok,
    }
    figures["passed"] = bool(
        max(groups.values()) <= 10 * tolerance
        and complementarity < COMPLEMENTARITY_TOLERANCE
        and figures["target_error_m"] <= TARGET_TOLERANCE
        and thrust_ok
    )
    return figures


def motion_figures(solution: Solution) -> dict[str, Any]:
    """How long the robot flies and how fast: the time [s] of the intervals whose both knots are
    airborne (every sole corner above AIRBORNE, so no corner can carry load), and the average
    horizontal speed [m/s] of the CoM from the first knot to the last."""
    com = solution.knots["com"]
    airborne = solution.knots["corners"][:, 2::3].min(axis=1) > AIRBORNE
    duration = solution.dt * (len(com) - 1)
    return {
        "airborne_s": round(float(solution.dt * np.sum(airborne[:-1] & airborne[1:])), 6),
        "horizontal_speed_mps": float(np.linalg.norm(com[-1, :2] - com[0, :2]) / duration),
    }


def solver_figures(solution: Solution) -> dict[str, Any]:
    return {
        "variables": solution.variables,
        "constraints": solution.constraints,
        "knots": len(solution.knots["com"]),
        "dt_s": solution.dt,
        "duration_s": solution.dt * (len(solution.knots["com"]) - 1),
        "iterations": solution.iterations,
        "max_iter": solution.config.solver.max_iter,  # IPOPT's limit on each step
        "retries": solution.retries,
        "status": solution.status,
        "build_s": round(solution.build_seconds, 3),
        "solve_s": round(solution.solve_seconds, 3),
        "homotopy": [
            {
                "eps": s.eps,
                "status": s.status,
                "iterations": s.iterations,
                "s": round(s.seconds, 3),
                "retry": s.retry,
            }
            for s in solution.steps
        ],
    }
