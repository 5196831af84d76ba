"""Solving a scenario: build the NLP once, then IPOPT over the complementarity homotopy.

Each homotopy step tightens eps (f_z c_z <= eps) and starts from the previous solution and its
multipliers (warm start with a small initial barrier parameter), so the later steps take few
iterations. A step that IPOPT does not solve (out of iterations, say: IPOPT's path, and so its
iteration count, depends on the CPU's rounding) is tried once more another way before the solve
fails: the first, cold step from where it stopped (warm-started: a fresh barrier and filter), a
later step from the previous step's solution in steps of eps of at most 10x. A step that fails
again raises TrajoptError with IPOPT's status and the largest violation.
"""

from __future__ import annotations

import ctypes
import functools
import itertools
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


COLD_BOUND_PUSH = 1e-5  # how far IPOPT moves the initial guess off its bounds (see _options)
RETRY_FACTOR = 10.0  # a retried warm step tightens eps by at most this factor at a time


@dataclass
class Step:
    eps: float
    status: str
    iterations: int
    seconds: float
    retry: str = ""  # how a retry differs from the planned step ("": the planned step)

    @property
    def solved(self) -> bool:
        return self.status in SUCCESS


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

    @property
    def retries(self) -> int:
        """The steps that were retries of a step IPOPT did not solve."""
        return sum(bool(step.retry) for step in self.steps)


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
            # IPOPT moves a start on a bound 1e-2 into the interior (absolute, as the bounds here
            # are 0): 1 cm for the corner heights of the feet on the floor, a distance the
            # contacts resolve to micrometres. 1e-5 leaves the guess where it is; cold jump
            # steps (the four library jumps): 286, 144, 176, 183 -> 154, 146, 124, 174
            ipopt["bound_push"] = ipopt["bound_frac"] = COLD_BOUND_PUSH
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
        """Run the homotopy (each unsolved step retried once); raise TrajoptError when a step
        stays unsolved."""
        lbx, ubx = self.problem.variable_bounds()
        lbg, ubg = self.problem.constraint_bounds()
        x0 = np.concatenate([self.guess.ravel(order="F"), [self.dt_guess]])
        bounds = {"lbx": lbx, "ubx": ubx, "lbg": lbg, "ubg": ubg}
        steps: list[Step] = []
        schedule = self.config.contacts.eps
        start = bounds | {"x0": np.clip(x0, lbx, ubx)}
        result = self._step(self.cold, start, schedule[0], "", steps, log)
        if not steps[-1].solved:
            note = "from where it stopped, warm-started"
            if log:
                log(f"homotopy eps={schedule[0]:g} unsolved ({steps[-1].status}): retrying {note}")
            start = bounds | self._warm_start(result)
            result = self._step(self._later, start, schedule[0], note, steps, log)
        self._check(result, steps)
        for previous, eps in itertools.pairwise(schedule):
            start = bounds | self._warm_start(result)
            result = self._step(self._later, start, eps, "", steps, log)
            if not steps[-1].solved:
                result = self._retry(start, previous, eps, steps, log)
            self._check(result, steps)
        x = np.array(result["x"]).ravel()
        g = np.array(result["g"]).ravel()
        lay, n = self.problem.layout, self.problem.knots
        return Solution(
            config=self.config,
            knots=lay.unpack(x[:-1].reshape(lay.size, n, order="F")),
            dt=float(x[-1]),
            x=x,
            constraint_values=g,
            constraint_groups=self.problem.group_slices(),
            lower=lbg,
            upper=ubg,
            steps=steps,
            build_seconds=self.build_seconds,
            variables=len(x),
            constraints=len(g),
        )

    @property
    def _later(self) -> Any:
        """The solver of the steps after the first: warm, or cold without the warm start."""
        return self.warm if self.config.solver.warm_start else self.cold

    def _warm_start(self, result: dict[str, Any]) -> dict[str, Any]:
        """A later step's start: the solution `result` (and its multipliers when warm)."""
        if not self.config.solver.warm_start:
            return {"x0": result["x"]}
        return {"x0": result["x"], "lam_x0": result["lam_x"], "lam_g0": result["lam_g"]}

    def _step(
        self,
        solver: Any,
        args: dict[str, Any],
        eps: float,
        retry: str,
        steps: list[Step],
        log: Callable[[str], None] | None,
    ) -> dict[str, Any]:
        """One IPOPT call at `eps` from `args`; its Step appended to `steps`."""
        start = clock.perf_counter()
        with interruptible():  # Ctrl-C and SIGTERM stop IPOPT and end the program
            result = solver(**args, p=self.problem.functions.parameters(eps))
        stats = solver.stats()
        seconds = clock.perf_counter() - start
        steps.append(Step(eps, stats["return_status"], int(stats["iter_count"]), seconds, retry))
        if log:
            log(
                f"homotopy eps={eps:g}: {stats['return_status']}, {stats['iter_count']} "
                f"iterations, {seconds:.1f} s" + (" (retry)" if retry else "")
            )
        return result

    def _retry(
        self,
        start: dict[str, Any],
        previous: float,
        eps: float,
        steps: list[Step],
        log: Callable[[str], None] | None,
    ) -> dict[str, Any]:
        """The step from `previous` to `eps` again from its `start` (the solution at
        `previous`), through values of eps at most RETRY_FACTOR apart; the last result."""
        schedule = finer_schedule(previous, eps)
        if log:
            log(
                f"homotopy eps={eps:g} unsolved ({steps[-1].status}): retrying from the "
                f"solution at eps={previous:g} through eps=" + ", ".join(f"{v:g}" for v in schedule)
            )
        result: dict[str, Any] = {}
        for value in schedule:
            note = f"retry of eps={eps:g} from eps={previous:g}"
            result = self._step(self._later, start, value, note, steps, log)
            if not steps[-1].solved:
                break
            start = start | self._warm_start(result)
        return result

    def _check(self, result: dict[str, Any], steps: list[Step]) -> None:
        """TrajoptError when the last step is unsolved: IPOPT's status, the iterations of
        every step and the largest constraint violation with its group."""
        if steps[-1].solved:
            return
        lbg, ubg = self.problem.constraint_bounds()
        worst = violation(np.array(result["g"]).ravel(), lbg, ubg)
        groups = self.problem.group_slices()
        where = max(groups, key=lambda name: worst[groups[name]].max(initial=0.0))
        retried = sum(step.iterations for step in steps if step.retry)
        raise TrajoptError(
            f"scenario '{self.config.scenario.name}' is infeasible or unsolved: IPOPT status "
            f"{steps[-1].status} at eps={steps[-1].eps:g} after "
            f"{sum(step.iterations for step in steps)} iterations"
            + (f" ({retried} of them retrying)" if retried else "")
            + f"; largest constraint violation {worst.max():.3g} (in '{where}')"
        )


def finer_schedule(previous: float, eps: float) -> list[float]:
    """The eps values from `previous` (excluded) to `eps` (included), evenly spaced in
    log(eps), each at most RETRY_FACTOR below the one before and at least two of them."""
    ratio = np.log(previous / eps) / np.log(RETRY_FACTOR)
    count = max(2, int(np.ceil(ratio - 1e-9)))
    return [float(v) for v in np.geomspace(previous, eps, count + 1)[1:]]


def solve(
    robot: Robot,
    config: TrajoptConfig,
    kinematics: RobotKinematics | None = None,
    log: Callable[[str], None] | None = None,
) -> Solution:
    """Build and solve one scenario."""
    return Prepared(robot, config, kinematics, log).solve(log)
