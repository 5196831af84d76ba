"""The per-knot and per-interval functions of the problem (CasADi SX, built once, mapped).

`knot(w, p)`: the ties between the knot's variables and the full kinematics (CoM, centroidal
momentum, sole-corner positions, net wrench of contact forces and thrusts about the CoM), the
contact conditions at the corners (relaxed complementarity f_z c_z <= eps, friction pyramid;
c_z >= 0 is a bound) and the running cost.

`interval(z, p)`, z = (w_k, w_k+1, dt): explicit-Euler multiple-shooting defects of the base pose,
joints, centroidal momentum and jets, the relaxed no-slip condition while loaded, and the rate
terms of the cost. It needs no kinematics, so its derivatives are cheap.

The cost weights, friction coefficient, posture and eps are parameters p (`parameters`), not
constants, so one compiled copy of the functions serves every config of a robot (compiled.py).
"""

from __future__ import annotations

from dataclasses import dataclass

import casadi as cs
import numpy as np

from motionkit.jet_ident.p250 import P250_COEFFS, thrust_acceleration
from motionkit.trajopt.config import TrajoptConfig
from motionkit.trajopt.kinematics import GRAVITY, RobotKinematics
from motionkit.trajopt.layout import MOMENTUM_UNIT, KnotLayout

NOMINAL_DT = 0.075  # s, scales the rate terms of the cost
KNOT_WEIGHTS = (
    "com_velocity", "angular_momentum", "joint_velocity", "posture", "base_orientation",
    "contact_force", "thrust", "thrust_rate", "complementarity",
)  # fmt: skip
INTERVAL_WEIGHTS = ("com_acceleration", "angular_momentum_rate", "throttle_rate")


@dataclass(frozen=True)
class KnotBlocks:
    """Physical values of one knot's blocks, as CasADi expressions."""

    values: dict[str, cs.SX]

    def __getitem__(self, name: str) -> cs.SX:
        return self.values[name]


def physical(layout: KnotLayout, w: cs.SX) -> KnotBlocks:
    return KnotBlocks({n: w[b.slice] * b.scale for n, b in layout.blocks.items()})


def quaternion_step(quat: cs.SX, omega: cs.SX, dt: cs.SX) -> cs.SX:
    """One explicit-Euler step of dq/dt = 1/2 (0, omega) x q (world-frame omega, (w, x, y, z)),
    renormalised so that every knot's quaternion stays a unit quaternion."""
    w, v = quat[0], quat[1:]
    rate = 0.5 * cs.vertcat(-cs.dot(omega, v), w * omega + cs.cross(omega, v))
    moved = quat + dt * rate
    return moved / cs.norm_2(moved)


def wrench(blocks: KnotBlocks, jet_pos: cs.SX, jet_dir: cs.SX, count: int) -> tuple[cs.SX, cs.SX]:
    """Total contact + thrust force [N] and its moment about the CoM [N m]; contact forces act
    at the corner variables, thrust (-z_jet T) at the jet frame origins."""
    com = blocks["com"]
    corners = cs.reshape(blocks["corners"], 3, count)
    forces = cs.reshape(blocks["forces"], 3, count)
    thrusts = jet_dir * cs.repmat(blocks["thrust"].T, 3, 1)  # thrust = -z_jet * T
    force = cs.sum2(forces) + cs.sum2(thrusts)
    moment = cs.SX.zeros(3)
    for i in range(count):
        moment += cs.cross(corners[:, i] - com, forces[:, i])
    for j in range(thrusts.shape[1]):
        moment += cs.cross(jet_pos[:, j] - com, thrusts[:, j])
    return force, moment


class ProblemFunctions:
    """The knot and interval functions of one robot and config."""

    def __init__(self, kinematics: RobotKinematics, config: TrajoptConfig, posture: np.ndarray):
        lay = kinematics.layout
        self.kinematics = kinematics
        self.layout = KnotLayout(lay.joints, lay.corners, lay.jets, kinematics.mass)
        self.config = config
        self.posture = posture
        self.knot = self._knot()
        self.interval = self._interval()

    def parameters(self, eps: float) -> np.ndarray:
        """The parameter vector p of both functions: eps, mu, the weights, the posture."""
        weights = self.config.weights
        return np.concatenate(
            [
                [eps, self.config.contacts.mu],
                [getattr(weights, name) for name in KNOT_WEIGHTS + INTERVAL_WEIGHTS],
                self.posture,
            ]
        )

    def _symbols(self) -> tuple[cs.SX, dict[str, cs.SX], cs.SX]:
        p = cs.SX.sym("p", 2 + len(KNOT_WEIGHTS) + len(INTERVAL_WEIGHTS) + self.layout.joints)
        names = KNOT_WEIGHTS + INTERVAL_WEIGHTS
        weights = {name: p[2 + i] for i, name in enumerate(names)}
        return p, weights, p[2 + len(names) :]

    def _knot(self) -> cs.Function:
        lay = self.layout
        w = cs.SX.sym("w", lay.size)
        p, weights, posture = self._symbols()
        eps, mu = p[0], p[1]
        b = physical(lay, w)
        com, momentum, corners, jet_pos, jet_dir = self.kinematics.knot(w[lay.q], w[lay.nu])
        force, moment = wrench(b, jet_pos, jet_dir, lay.corners)
        ties = cs.vertcat(
            b["com"] - com,
            momentum[:3] / lay.mass - b["com_velocity"],
            (momentum[3:] - b["angular_momentum"]) / MOMENTUM_UNIT,
            b["corners"] - cs.vec(corners),
            (b["net_force"] - force) / lay.blocks["net_force"].scale,
            (b["net_moment"] - moment) / lay.blocks["net_moment"].scale,
        )
        forces = cs.reshape(w[lay["forces"]], 3, lay.corners)  # scaled
        normal = forces[2, :].T
        heights = cs.reshape(b["corners"], 3, lay.corners)[2, :].T
        friction = cs.vertcat(
            mu * normal - forces[0, :].T,
            mu * normal + forces[0, :].T,
            mu * normal - forces[1, :].T,
            mu * normal + forces[1, :].T,
        )
        upright = w[lay["base_quaternion"]] - cs.DM([1.0, 0.0, 0.0, 0.0])
        cost = (
            weights["com_velocity"] * cs.sumsqr(b["com_velocity"])
            + weights["angular_momentum"] * cs.sumsqr(w[lay["angular_momentum"]])
            + weights["joint_velocity"] * cs.sumsqr(b["joint_velocities"])
            + weights["posture"] * cs.sumsqr(b["joints"] - posture)
            + weights["base_orientation"] * cs.sumsqr(upright)
            + weights["contact_force"] * cs.sumsqr(w[lay["forces"]])
            + weights["thrust"] * cs.sumsqr(w[lay["thrust"]])
            + weights["thrust_rate"] * cs.sumsqr(w[lay["thrust_rate"]])
            + weights["complementarity"] * cs.dot(normal, heights)
        )
        constraints = cs.vertcat(ties, eps - normal * heights, friction)
        return cs.Function("knot", [w, p], [constraints, cost], ["w", "p"], ["g", "cost"])

    def knot_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """Bounds of the knot constraints: ties = 0, then complementarity and friction >= 0."""
        lay = self.layout
        ties = 9 + 3 * lay.corners + 6
        size = ties + 5 * lay.corners
        lower = np.zeros(size)
        upper = np.concatenate([np.zeros(ties), np.full(size - ties, np.inf)])
        return lower, upper

    def _interval(self) -> cs.Function:
        lay, config = self.layout, self.config
        z = cs.SX.sym("z", 2 * lay.size + 1)
        p, weights, _ = self._symbols()
        w0, w1, dt = z[: lay.size], z[lay.size : 2 * lay.size], z[-1]
        a, b = physical(lay, w0), physical(lay, w1)
        gravity = cs.DM([0.0, 0.0, -GRAVITY])
        acceleration = a["net_force"] / lay.mass + gravity
        defects = [
            b["base_position"] - a["base_position"] - dt * a["base_velocity"],
            b["base_quaternion"]
            - quaternion_step(a["base_quaternion"], a["base_angular_velocity"], dt),
            b["joints"] - a["joints"] - dt * a["joint_velocities"],
            b["com_velocity"] - a["com_velocity"] - dt * acceleration,
            (b["angular_momentum"] - a["angular_momentum"] - dt * a["net_moment"]) / MOMENTUM_UNIT,
            (b["thrust"] - a["thrust"] - dt * a["thrust_rate"]) / lay.blocks["thrust"].scale,
        ]
        if config.jets.model == "p250":
            tddot = thrust_acceleration(P250_COEFFS, a["thrust"], a["thrust_rate"], a["throttle"])
            scale = lay.blocks["thrust_rate"].scale
            defects.append((b["thrust_rate"] - a["thrust_rate"] - dt * tddot) / scale)
        normal = cs.reshape(w0[lay["forces"]], 3, lay.corners)[2, :]
        step = cs.reshape(b["corners"] - a["corners"], 3, lay.corners)[:2, :]
        slip = cs.vec(cs.repmat(normal, 2, 1) * step)  # |f_z (p_k+1 - p_k)| <= slip_eps
        change = w1 - w0
        cost = (
            weights["com_acceleration"] * cs.sumsqr(b["com_velocity"] - a["com_velocity"])
            + weights["angular_momentum_rate"] * cs.sumsqr(change[lay["angular_momentum"]])
            + weights["throttle_rate"] * cs.sumsqr(change[lay["throttle"]])
        ) / NOMINAL_DT**2
        g = cs.vertcat(*defects, slip)
        return cs.Function("interval", [z, p], [g, cost], ["z", "p"], ["g", "cost"])

    def interval_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """Defects = 0, then -slip_eps <= slip <= slip_eps."""
        lay, slip_eps = self.layout, self.config.contacts.slip_eps
        defects = self.interval.size1_out(0) - 2 * lay.corners
        lower = np.concatenate([np.zeros(defects), np.full(2 * lay.corners, -slip_eps)])
        upper = np.concatenate([np.zeros(defects), np.full(2 * lay.corners, slip_eps)])
        return lower, upper
