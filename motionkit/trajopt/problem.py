"""The multiple-shooting NLP: knot columns W (scaled, one column per knot) and the time step dt.

x = (vec(W), dt); g = (knot constraints of every knot, interval constraints of every interval);
f = (sum of knot and interval costs) / N. The knot function is mapped over the columns and the
interval function over (w_k, w_k+1, dt); the gradient, Jacobian and Hessian of the Lagrangian
given to IPOPT are assembled from the terms' own small derivatives (assembly.py), compiled to C
where a compiler is available (compiled.py). The NLP parameter is `functions.parameters(eps)`.
Scenarios add bounds on knot variables through `bound` and `fix`.
"""

from __future__ import annotations

import os
from collections.abc import Callable
from typing import Any

import casadi as cs
import numpy as np

from motionkit.trajopt.assembly import Scatter
from motionkit.trajopt.compiled import compile_groups
from motionkit.trajopt.config import TrajoptConfig
from motionkit.trajopt.dynamics import ProblemFunctions
from motionkit.trajopt.layout import KnotLayout

QUATERNION_BOX = 1.5  # |component| bound of the base quaternion variables (see _default_bounds)
# threads for the term functions (IPOPT itself and MUMPS run on one)
THREADS = int(os.environ.get("MOTIONKIT_TRAJOPT_THREADS", min(2, os.cpu_count() or 1)))


def _derivatives(function: cs.Function) -> tuple[cs.Function, ...]:
    """Gradient of the cost, Jacobian of g and upper-triangular Hessian of the Lagrangian of a
    term function (inputs: variables, parameters; outputs g, cost)."""
    inputs = [cs.SX.sym(function.name_in(i), function.sparsity_in(i)) for i in range(2)]
    g, cost = function(*inputs)
    z = inputs[0]
    sigma, lam = cs.SX.sym("sigma"), cs.SX.sym("lam", g.shape[0])
    hessian = cs.triu(cs.hessian(sigma * cost + cs.dot(lam, g), z)[0])
    name = function.name()
    return (
        cs.Function(f"{name}_grad", inputs, [cs.gradient(cost, z)]),
        cs.Function(f"{name}_jac", inputs, [cs.jacobian(g, z)]),
        cs.Function(f"{name}_hess", [*inputs, sigma, lam], [hessian]),
    )


def _mapped(function: cs.Function, count: int) -> cs.Function:
    """`count` copies of a term function, evaluated on `THREADS` threads."""
    if THREADS > 1:
        return function.map(count, "thread", THREADS)
    return function.map(count, "serial")


class Problem:
    def __init__(self, functions: ProblemFunctions, knots: int) -> None:
        self.functions, self.knots = functions, knots
        lay = self.layout
        self.reference: dict[str, cs.MX] = {}  # set by nlp()
        self.lower = np.full((lay.size, knots), -np.inf)
        self.upper = np.full((lay.size, knots), np.inf)
        self._default_bounds()

    @property
    def layout(self) -> KnotLayout:
        return self.functions.layout

    @property
    def config(self) -> TrajoptConfig:
        return self.functions.config

    # -- bounds ---------------------------------------------------------------------------------
    def bound(self, knot: int | slice, block: str, lower: object, upper: object) -> None:
        """Bounds in physical units on one block at some knots."""
        b = self.layout.blocks[block]
        low = np.asarray(lower, dtype=float) / b.scale
        high = np.asarray(upper, dtype=float) / b.scale
        column = isinstance(knot, slice)
        self.lower[b.slice, knot] = low[:, None] if column else low
        self.upper[b.slice, knot] = high[:, None] if column else high

    def fix(self, knot: int | slice, block: str, value: object) -> None:
        self.bound(knot, block, value, value)

    def bound_corners(
        self, knot: int, corners: range, axis: int, lower: object, upper: object
    ) -> None:
        """Bounds on one coordinate (0 x, 1 y, 2 z) of some sole corners at a knot [m]."""
        start = self.layout.blocks["corners"].start
        rows = [start + 3 * c + axis for c in corners]
        self.lower[rows, knot] = lower
        self.upper[rows, knot] = upper

    def _default_bounds(self) -> None:
        config, lay = self.config, self.layout
        robot = self.functions.kinematics.robot
        limits = robot.limits
        speed = np.minimum(limits.velocity, config.solver.max_joint_velocity)
        every = slice(None)
        # a box the unit quaternions of the knots never reach: at [-1, 1] the upright
        # orientation (w = 1), where the cost pulls every knot, sat on the bound, which the
        # normalised Euler step implies there (degenerate, and a barrier pushing away from it)
        self.bound(
            every, "base_quaternion", -QUATERNION_BOX * np.ones(4), QUATERNION_BOX * np.ones(4)
        )
        self.bound(every, "joints", limits.lower, limits.upper)
        self.bound(every, "joint_velocities", -speed, speed)
        t_max = np.array([jet.t_max for jet in robot.spec.jets]) * config.scenario.thrust_fraction
        self.bound(every, "thrust", np.zeros(lay.jets), t_max)
        self.bound(every, "throttle", np.zeros(lay.jets), np.full(lay.jets, 100.0))
        if config.jets.model == "rate":
            rate = np.full(lay.jets, config.jets.max_rate)
            self.bound(every, "thrust_rate", -rate, rate)
        forces = lay.blocks["forces"]
        self.lower[forces.start + 2 : forces.start + forces.size : 3, :] = 0.0  # f_z >= 0
        for knot in range(self.knots):
            self.bound_corners(knot, range(lay.corners), 2, 0.0, np.inf)  # above the floor

    def dt_bounds(self) -> tuple[float, float]:
        solver = self.config.solver
        return (solver.dt, solver.dt) if solver.dt > 0 else (solver.dt_min, solver.dt_max)

    def variable_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        low, high = self.dt_bounds()
        lbx = np.concatenate([self.lower.ravel(order="F"), [low]])
        ubx = np.concatenate([self.upper.ravel(order="F"), [high]])
        return lbx, ubx

    def constraint_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        n = self.knots
        knot_low, knot_high = self.functions.knot_bounds()
        int_low, int_high = self.functions.interval_bounds()
        return (
            np.concatenate([np.tile(knot_low, n), np.tile(int_low, n - 1)]),
            np.concatenate([np.tile(knot_high, n), np.tile(int_high, n - 1)]),
        )

    def group_slices(self) -> dict[str, slice]:
        """Where the knot ties, contact conditions, defects and slip bounds lie in g."""
        lay, n = self.layout, self.knots
        ties = 15 + 3 * lay.corners
        knot_size = ties + 5 * lay.corners
        int_size = self.functions.interval.size1_out(0)
        defects = int_size - 2 * lay.corners
        knot_rows = np.arange(n * knot_size).reshape(n, knot_size)
        int_rows = n * knot_size + np.arange((n - 1) * int_size).reshape(n - 1, int_size)
        return {
            "kinematic ties": knot_rows[:, :ties].ravel(),
            "contact": knot_rows[:, ties:].ravel(),
            "dynamics defects": int_rows[:, :defects].ravel(),
            "no-slip": int_rows[:, defects:].ravel(),
        }

    # -- the NLP and its derivatives -----------------------------------------------------------
    def nlp(
        self, log: Callable[[str], None] | None = None
    ) -> tuple[dict[str, cs.MX], dict[str, Any]]:
        """The NLP dict and the nlpsol options that give IPOPT the assembled derivatives."""
        fn, lay, n = self.functions, self.layout, self.knots
        size = lay.size
        nx = n * size + 1
        x, p = cs.MX.sym("x", nx), cs.MX.sym("p", fn.knot.size1_in(1))
        W = cs.reshape(x[:-1], size, n)
        dt = x[-1]
        Z = cs.vertcat(W[:, :-1], W[:, 1:], cs.repmat(dt, 1, n - 1))
        (knot, knot_grad, knot_jac, knot_hess), (interval, int_grad, int_jac, int_hess) = (
            compile_groups([fn.knot, fn.interval], _derivatives, log)
        )

        def objective_and_constraints(knot: cs.Function, interval: cs.Function) -> list[cs.MX]:
            g_knot, c_knot = _mapped(knot, n)(W, p)
            g_int, c_int = _mapped(interval, n - 1)(Z, p)
            f = (cs.sum2(c_knot) + cs.sum2(c_int)) / n
            return [f, cs.vertcat(cs.vec(g_knot), cs.vec(g_int))]

        f, g = objective_and_constraints(knot, interval)
        # the same f and g from the uncompiled functions, for checks by automatic differentiation
        reference = objective_and_constraints(fn.knot, fn.interval)
        self.reference = {"f": reference[0], "g": reference[1]}
        ng_knot, ng_int, ng = fn.knot.size1_out(0), fn.interval.size1_out(0), g.shape[0]

        # index maps of the copies: knot k -> its columns; interval k -> (w_k, w_k+1, dt)
        knot_cols = [k * size + np.arange(size) for k in range(n)]
        int_cols = [
            np.concatenate([k * size + np.arange(2 * size), [nx - 1]]) for k in range(n - 1)
        ]
        knot_rows = [k * ng_knot + np.arange(ng_knot) for k in range(n)]
        int_rows = [n * ng_knot + k * ng_int + np.arange(ng_int) for k in range(n - 1)]

        # gradient of f
        grad_int = _mapped(int_grad, n - 1)(Z, p)
        pad = cs.MX.zeros(size, 1)
        grad_w = (
            _mapped(knot_grad, n)(W, p)
            + cs.horzcat(grad_int[:size, :], pad)
            + cs.horzcat(pad, grad_int[size : 2 * size, :])
        )
        grad = cs.vertcat(cs.vec(grad_w), cs.sum2(grad_int[-1, :])) / n

        # Jacobian of g
        jac_knot = Scatter(knot_jac.sparsity_out(0), knot_rows, knot_cols, (ng, nx))
        jac_int = Scatter(int_jac.sparsity_out(0), int_rows, int_cols, (ng, nx))
        jac = jac_knot(_mapped(knot_jac, n)(W, p))
        jac += jac_int(_mapped(int_jac, n - 1)(Z, p))

        # Hessian of the Lagrangian (upper triangle)
        sigma, lam = cs.MX.sym("sigma"), cs.MX.sym("lam", ng)
        lam_knot = cs.reshape(lam[: n * ng_knot], ng_knot, n)
        lam_int = cs.reshape(lam[n * ng_knot :], ng_int, n - 1)
        hess_knot = Scatter(knot_hess.sparsity_out(0), knot_cols, knot_cols, (nx, nx))
        hess_int = Scatter(int_hess.sparsity_out(0), int_cols, int_cols, (nx, nx))
        hess = hess_knot(_mapped(knot_hess, n)(W, p, sigma / n, lam_knot)) + hess_int(
            _mapped(int_hess, n - 1)(Z, p, sigma / n, lam_int)
        )
        options = {
            "grad_f": cs.Function("grad_f", [x, p], [f, grad]),
            "jac_g": cs.Function("jac_g", [x, p], [g, jac]),
            "hess_lag": cs.Function("hess_lag", [x, p, sigma, lam], [cs.triu(hess)]),
        }
        return {"x": x, "f": f, "g": g, "p": p}, options
