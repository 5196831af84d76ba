"""Solving a scenario: build the NLP once, then IPOPT over the complementarity homotopy.

Each homotopy step tightens eps (f_z c_z <= eps) and starts from the previous solution and its
multipliers (warm start with a small initial barrier parameter), so the later steps take few
iterations. A failed final step raises TrajoptError with IPOPT's status and the largest violation.
"""

from __future__ import annotations

import ctypes
import functools
import time as clock
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import casadi as cs
import numpy as np

from motionkit.core.errors import TrajoptError
from motionkit.robot import Robot
from motionkit.runtime.interrupts import interruptible
from motionkit.trajopt.config import TrajoptConfig
from motionkit.trajopt.dynamics import ProblemFunctions
from motionkit.trajopt.kinematics import RobotKinematics
from motionkit.trajopt.problem import Problem
from motionkit.trajopt.scenarios import apply_scenario

SUCCESS = ("Solve_Succeeded", "Solved_To_Acceptable_Level")


@dataclass
class Step:
    eps: float
    status: str
    iterations: int
    seconds: float


@dataclass
class Solution:
    """The solved knots in physical units, with the solver's figures."""

    config: TrajoptConfig
    knots: dict[str, np.ndarray]  # block name -> (N, size)
    dt: float
    x: np.ndarray  # the scaled decision vector
    constraint_values: np.ndarray
    constraint_groups: dict[str, np.ndarray]  # rows of g per kind of constraint
    lower: np.ndarray  # constraint bounds
    upper: np.ndarray
    steps: list[Step]
    build_seconds: float
    variables: int
    constraints: int
    metrics: dict[str, Any] = field(default_factory=dict)

    @property
    def time(self) -> np.ndarray:
        return np.arange(len(self.knots["com"])) * self.dt

    @property
    def iterations(self) -> int:
        return sum(step.iterations for step in self.steps)

    @property
    def solve_seconds(self) -> float:
        return sum(step.seconds for step in self.steps)

    @property
    def status(self) -> str:
        return self.steps[-1].status


@functools.cache
def keep_freed_memory() -> None:
    """Let glibc keep freed memory instead of unmapping it: MUMPS allocates and frees its
    workspace at every factorization, and unmapping it each time showed as system time (page
    faults), about a tenth of IPOPT's linear-solve time at N = 100. No-op without glibc."""
    mallopt = getattr(ctypes.CDLL(None), "mallopt", None)
    if mallopt is None:
        return
    m_trim_threshold, m_mmap_max = -1, -4  # glibc's malloc.h
    mallopt(m_mmap_max, 0)
    mallopt(m_trim_threshold, 1 << 30)


def violation(values: np.ndarray, lower: np.ndarray, upper: np.ndarray) -> np.ndarray:
    return np.maximum(np.maximum(lower - values, values - upper), 0.0)


class Prepared:
    """A problem and its IPOPT solvers, built once (reuse it for many targets of one config)."""

    def __init__(
        self,
        robot: Robot,
        config: TrajoptConfig,
        kinematics: RobotKinematics | None = None,
        log: Callable[[str], None] | None = None,
    ) -> None:
        start = clock.perf_counter()
        keep_freed_memory()
        self.kinematics = kinematics or RobotKinematics(robot)
        posture = robot.spec.posture_angles()
        functions = ProblemFunctions(
            self.kinematics, config, np.array([posture[name] for name in robot.joint_names])
        )
        self.config = config
        self.problem = Problem(functions, config.scenario.knots)
        self.guess, self.dt_guess = apply_scenario(self.problem)
        nlp, derivatives = self.problem.nlp(log)
        self.cold = cs.nlpsol("trajopt", "ipopt", nlp, derivatives | self._options(warm=False))
        self.warm = (
            cs.nlpsol("trajopt_warm", "ipopt", nlp, derivatives | self._options(warm=True))
            if config.solver.warm_start and len(config.contacts.eps) > 1
            else self.cold
        )
        self.build_seconds = clock.perf_counter() - start

    def _options(self, warm: bool) -> dict[str, Any]:
        solver = self.config.solver
        ipopt: dict[str, Any] = {
            "print_level": solver.print_level,
            "tol": solver.tol,
            "constr_viol_tol": solver.constr_viol_tol,
            "max_iter": solver.max_iter,
            "max_cpu_time": solver.max_cpu_time,
            "linear_solver": "mumps",
            "mu_strategy": solver.mu_strategy,
            "sb": "yes",
        }
        if not warm:  # the cold step's barrier oracles (config.py: why)
            ipopt["mu_oracle"] = solver.cold_mu_oracle
            # mu on entering the monotone mode from the quality function, not the average
            # complementarity; iterations in all (default -> this): take-off 362 -> 148, landing
            # 129 -> 127, jump 270 -> 256, walk-to-fly 232 -> 196, flight 26 -> 26
            ipopt["fixed_mu_oracle"] = "quality-function"
        ipopt |= solver.options
        if solver.hessian == "limited-memory":
            ipopt["hessian_approximation"] = "limited-memory"
        if warm:
            ipopt |= {
                "warm_start_init_point": "yes",
                "mu_init": 1e-4,
                "warm_start_bound_push": 1e-6,
                "warm_start_slack_bound_push": 1e-6,
                "warm_start_mult_bound_push": 1e-6,
            }
        return {"ipopt": ipopt, "print_time": False, "calc_lam_p": False}

    def solve(self, log: Callable[[str], None] | None = None) -> Solution:
        """Run the homotopy; raise TrajoptError when the last step does not converge."""
        lbx, ubx = self.problem.variable_bounds()
        lbg, ubg = self.problem.constraint_bounds()
        x0 = np.concatenate([self.guess.ravel(order="F"), [self.dt_guess]])
        x0 = np.clip(x0, lbx, ubx)
        args: dict[str, Any] = {"x0": x0, "lbx": lbx, "ubx": ubx, "lbg": lbg, "ubg": ubg}
        steps: list[Step] = []
        result: dict[str, Any] = {}
        for i, eps in enumerate(self.config.contacts.eps):
            solver = self.cold if i == 0 or not self.config.solver.warm_start else self.warm
            start = clock.perf_counter()
            with interruptible():  # Ctrl-C and SIGTERM stop IPOPT and end the program
                result = solver(**args, p=self.problem.functions.parameters(eps))
            stats = solver.stats()
            steps.append(
                Step(
                    eps,
                    stats["return_status"],
                    int(stats["iter_count"]),
                    clock.perf_counter() - start,
                )
            )
            if log:
                log(
                    f"homotopy eps={eps:g}: {stats['return_status']}, "
                    f"{stats['iter_count']} iterations, {steps[-1].seconds:.1f} s"
                )
            args["x0"] = result["x"]
            if self.config.solver.warm_start:
                args["lam_x0"], args["lam_g0"] = result["lam_x"], result["lam_g"]
        x = np.array(result["x"]).ravel()
        g = np.array(result["g"]).ravel()
        lay, n = self.problem.layout, self.problem.knots
        worst = violation(g, lbg, ubg)
        groups = self.problem.group_slices()
        if steps[-1].status not in SUCCESS:
            where = max(groups, key=lambda name: worst[groups[name]].max(initial=0.0))
            raise TrajoptError(
                f"scenario '{self.config.scenario.name}' is infeasible or unsolved: IPOPT status "
                f"{steps[-1].status} after {sum(s.iterations for s in steps)} iterations; largest "
                f"constraint violation {worst.max():.3g} (in '{where}')"
            )
        return Solution(
            config=self.config,
            knots=lay.unpack(x[:-1].reshape(lay.size, n, order="F")),
            dt=float(x[-1]),
            x=x,
            constraint_values=g,
            constraint_groups=groups,
            lower=lbg,
            upper=ubg,
            steps=steps,
            build_seconds=self.build_seconds,
            variables=len(x),
            constraints=len(g),
        )


def solve(
    robot: Robot,
    config: TrajoptConfig,
    kinematics: RobotKinematics | None = None,
    log: Callable[[str], None] | None = None,
) -> Solution:
    """Build and solve one scenario."""
    return Prepared(robot, config, kinematics, log).solve(log)
