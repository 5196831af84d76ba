"""The per-knot and per-interval functions of the problem (CasADi SX, built once, mapped).

`knot(w, eps)`: the ties between the centroidal state and the full kinematics (CoM, centroidal
momentum), the contact conditions at the eight corners (above the floor, relaxed complementarity
f_z c_z <= eps, friction pyramid) and the running cost; it also returns the corner and jet
kinematics that `interval` needs, so that they are computed once per knot.

`interval(w_k, w_k1, kin_k, kin_k1, dt)`: explicit-Euler multiple-shooting defects of the base
pose, joints, centroidal momentum and jets, and the relaxed no-slip condition while loaded.
"""

from __future__ import annotations

from dataclasses import dataclass

import casadi as cs
import numpy as np

from motionkit.trajopt.config import TrajoptConfig
from motionkit.trajopt.jets import thrust_acceleration
from motionkit.trajopt.kinematics import GRAVITY, RobotKinematics
from motionkit.trajopt.layout import MOMENTUM_UNIT, KnotLayout

NOMINAL_DT = 0.075  # s, scales the rate terms of the cost


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


def wrench(
    blocks: KnotBlocks, corners: cs.SX, jet_pos: cs.SX, jet_dir: cs.SX, count: int
) -> tuple[cs.SX, cs.SX]:
    """Total contact + thrust force [N] and its moment about the CoM [N m]."""
    com = blocks["com"]
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

    @property
    def kin_size(self) -> int:
        lay = self.layout
        return 3 * lay.corners + 6 * lay.jets

    def split_kin(self, kin: cs.SX) -> tuple[cs.SX, cs.SX, cs.SX]:
        c, j = self.layout.corners, self.layout.jets
        corners = cs.reshape(kin[: 3 * c], 3, c)
        jet_pos = cs.reshape(kin[3 * c : 3 * c + 3 * j], 3, j)
        jet_dir = cs.reshape(kin[3 * c + 3 * j :], 3, j)
        return corners, jet_pos, jet_dir

    def _knot(self) -> cs.Function:
        lay, weights, mu = self.layout, self.config.weights, self.config.contacts.mu
        w, eps = cs.SX.sym("w", lay.size), cs.SX.sym("eps")
        b = physical(lay, w)
        com, momentum, corners, jet_pos, jet_dir = self.kinematics.knot(w[lay.q], w[lay.nu])
        ties = cs.vertcat(
            b["com"] - com,
            momentum[:3] / lay.mass - b["com_velocity"],
            (momentum[3:] - b["angular_momentum"]) / MOMENTUM_UNIT,
        )
        forces = cs.reshape(w[lay["forces"]], 3, lay.corners)  # scaled
        heights = corners[2, :].T
        normal = forces[2, :].T
        friction = cs.vertcat(
            mu * normal - forces[0, :].T,
            mu * normal + forces[0, :].T,
            mu * normal - forces[1, :].T,
            mu * normal + forces[1, :].T,
        )
        contact = cs.vertcat(heights, eps - normal * heights, friction)  # all >= 0
        upright = w[lay["base_quaternion"]] - cs.DM([1.0, 0.0, 0.0, 0.0])
        cost = (
            weights.com_velocity * cs.sumsqr(b["com_velocity"])
            + weights.angular_momentum * cs.sumsqr(w[lay["angular_momentum"]])
            + weights.joint_velocity * cs.sumsqr(b["joint_velocities"])
            + weights.posture * cs.sumsqr(b["joints"] - self.posture)
            + weights.base_orientation * cs.sumsqr(upright)
            + weights.contact_force * cs.sumsqr(w[lay["forces"]])
            + weights.thrust * cs.sumsqr(w[lay["thrust"]])
            + weights.thrust_rate * cs.sumsqr(w[lay["thrust_rate"]])
        )
        kin = cs.vertcat(cs.vec(corners), cs.vec(jet_pos), cs.vec(jet_dir))
        return cs.Function(
            "knot",
            [w, eps],
            [ties, contact, cost, kin],
            ["w", "eps"],
            ["ties", "contact", "cost", "kin"],
            {"cse": True},
        )

    def _interval(self) -> cs.Function:
        lay, weights, config = self.layout, self.config.weights, self.config
        w0, w1 = cs.SX.sym("w0", lay.size), cs.SX.sym("w1", lay.size)
        kin0, kin1 = cs.SX.sym("kin0", self.kin_size), cs.SX.sym("kin1", self.kin_size)
        dt = cs.SX.sym("dt")
        a, b = physical(lay, w0), physical(lay, w1)
        corners0, jet_pos, jet_dir = self.split_kin(kin0)
        corners1, _, _ = self.split_kin(kin1)
        force, moment = wrench(a, corners0, jet_pos, jet_dir, lay.corners)
        gravity = cs.DM([0.0, 0.0, -GRAVITY])
        acceleration = force / lay.mass + gravity
        defects = [
            b["base_position"] - a["base_position"] - dt * a["base_velocity"],
            b["base_quaternion"]
            - quaternion_step(a["base_quaternion"], a["base_angular_velocity"], dt),
            b["joints"] - a["joints"] - dt * a["joint_velocities"],
            b["com_velocity"] - a["com_velocity"] - dt * acceleration,
            (b["angular_momentum"] - a["angular_momentum"] - dt * moment) / MOMENTUM_UNIT,
            (b["thrust"] - a["thrust"] - dt * a["thrust_rate"]) / lay.blocks["thrust"].scale,
        ]
        if config.jets.model == "p250":
            tddot = thrust_acceleration(a["thrust"], a["thrust_rate"], a["throttle"])
            defects.append((b["thrust_rate"] - a["thrust_rate"] - dt * tddot) / 100.0)
        normal = cs.reshape(w0[lay["forces"]], 3, lay.corners)[2, :]
        step = corners1[:2, :] - corners0[:2, :]
        slip = cs.vec(cs.repmat(normal, 2, 1) * step)  # |f_z (p_k+1 - p_k)| <= slip_eps
        rates = b["com_velocity"] - a["com_velocity"], w1 - w0
        h_rate = (w1 - w0)[lay["angular_momentum"]]
        cost = (
            weights.com_acceleration * cs.sumsqr(rates[0]) / NOMINAL_DT**2
            + weights.angular_momentum_rate * cs.sumsqr(h_rate) / NOMINAL_DT**2
            + weights.throttle_rate * cs.sumsqr(rates[1][lay["throttle"]]) / NOMINAL_DT**2
        )
        return cs.Function(
            "interval",
            [w0, w1, kin0, kin1, dt],
            [cs.vertcat(*defects), slip, cost],
            ["w0", "w1", "kin0", "kin1", "dt"],
            ["defects", "slip", "cost"],
            {"cse": True},
        )
