"""The multiple-shooting NLP: knot columns W (scaled, one column per knot) and the time step.

The knot and interval functions are mapped over the columns (one SX graph each, evaluated N
times), so the NLP is a small MX graph and CasADi builds its exact Hessian in a second or two.
Scenarios add bounds on knots and a few extra constraints through `bound`, `fix` and
`constrain`.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import casadi as cs
import numpy as np

from motionkit.trajopt.config import TrajoptConfig
from motionkit.trajopt.dynamics import ProblemFunctions
from motionkit.trajopt.layout import KnotLayout


@dataclass
class ConstraintGroup:
    name: str
    expr: cs.MX
    lower: np.ndarray
    upper: np.ndarray


@dataclass
class Problem:
    functions: ProblemFunctions
    knots: int
    W: cs.MX = field(init=False)
    dt: cs.MX = field(init=False)
    eps: cs.MX = field(init=False)
    kin: cs.MX = field(init=False)
    groups: list[ConstraintGroup] = field(default_factory=list)

    def __post_init__(self) -> None:
        lay, n = self.layout, self.knots
        self.W = cs.MX.sym("W", lay.size, n)
        self.dt = cs.MX.sym("dt")
        self.eps = cs.MX.sym("eps")
        fn = self.functions
        knot = fn.knot.map(n, "serial")(self.W, self.eps)
        ties, contact, knot_cost, self.kin = knot
        interval = fn.interval.map(n - 1, "serial")(
            self.W[:, :-1], self.W[:, 1:], self.kin[:, :-1], self.kin[:, 1:], self.dt
        )
        defects, slip, interval_cost = interval
        self.cost = (cs.sum2(knot_cost) + cs.sum2(interval_cost)) / n
        slip_eps = self.config.contacts.slip_eps
        self.constrain("ties", cs.vec(ties), 0.0, 0.0)
        self.constrain("defects", cs.vec(defects), 0.0, 0.0)
        self.constrain("contact", cs.vec(contact), 0.0, np.inf)
        self.constrain("slip", cs.vec(slip), -slip_eps, slip_eps)
        self.lower = np.full((lay.size, n), -np.inf)
        self.upper = np.full((lay.size, n), np.inf)
        self._default_bounds()

    @property
    def layout(self) -> KnotLayout:
        return self.functions.layout

    @property
    def config(self) -> TrajoptConfig:
        return self.functions.config

    # -- building -------------------------------------------------------------------------------
    def constrain(self, name: str, expr: cs.MX, lower: float | np.ndarray, upper: float | np.ndarray):
        size = expr.shape[0]
        self.groups.append(
            ConstraintGroup(
                name, expr, np.broadcast_to(lower, size).copy(), np.broadcast_to(upper, size).copy()
            )
        )

    def bound(self, knot: int | slice, block: str, lower: object, upper: object) -> None:
        """Bounds in physical units on one block at some knots."""
        b = self.layout.blocks[block]
        low = np.asarray(lower, dtype=float) / b.scale
        high = np.asarray(upper, dtype=float) / b.scale
        self.lower[b.slice, knot] = low[:, None] if low.ndim == 1 else low
        self.upper[b.slice, knot] = high[:, None] if high.ndim == 1 else high

    def fix(self, knot: int | slice, block: str, value: object) -> None:
        self.bound(knot, block, value, value)

    def corners(self, knot: int) -> cs.MX:
        """Sole-corner positions (3 x C, world) at a knot, as an expression."""
        return cs.reshape(self.kin[: 3 * self.layout.corners, knot], 3, self.layout.corners)

    def column(self, knot: int, block: str) -> cs.MX:
        b = self.layout.blocks[block]
        return self.W[b.slice, knot] * b.scale

    def _default_bounds(self) -> None:
        config, lay = self.config, self.layout
        robot = self.functions.kinematics.robot
        limits = robot.limits
        speed = np.minimum(limits.velocity, config.solver.max_joint_velocity)
        every = slice(None)
        self.bound(every, "base_quaternion", -np.ones(4), np.ones(4))
        self.bound(every, "joints", limits.lower, limits.upper)
        self.bound(every, "joint_velocities", -speed, speed)
        t_max = np.array([jet.t_max for jet in robot.spec.jets]) * config.scenario.thrust_fraction
        self.bound(every, "thrust", np.zeros(lay.jets), t_max)
        self.bound(every, "throttle", np.zeros(lay.jets), np.full(lay.jets, 100.0))
        if config.jets.model == "rate":
            rate = np.full(lay.jets, config.jets.max_rate)
            self.bound(every, "thrust_rate", -rate, rate)
        normal = self.layout.blocks["forces"]
        self.lower[normal.start + 2 : normal.start + normal.size : 3, :] = 0.0

    # -- the NLP --------------------------------------------------------------------------------
    def dt_bounds(self) -> tuple[float, float]:
        solver = self.config.solver
        return (solver.dt, solver.dt) if solver.dt > 0 else (solver.dt_min, solver.dt_max)

    def nlp(self) -> dict[str, cs.MX]:
        x = cs.vertcat(cs.vec(self.W), self.dt)
        g = cs.vertcat(*(group.expr for group in self.groups))
        return {"x": x, "f": self.cost, "g": g, "p": self.eps}

    def variable_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        low, high = self.dt_bounds()
        lbx = np.concatenate([self.lower.ravel(order="F"), [low]])
        ubx = np.concatenate([self.upper.ravel(order="F"), [high]])
        return lbx, ubx

    def constraint_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        return (
            np.concatenate([g.lower for g in self.groups]),
            np.concatenate([g.upper for g in self.groups]),
        )

    def group_slices(self) -> dict[str, slice]:
        out, start = {}, 0
        for group in self.groups:
            size = group.expr.shape[0]
            out[group.name] = slice(start, start + size)
            start += size
        return out
