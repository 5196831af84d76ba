"""The decision variables of one knot: named blocks, each with a scale (physical = scale x value).

Scaling keeps every variable near 1 for IPOPT: forces in units of m g / 8 (the weight share of
one of the eight corners), thrust in 100 N, angular momentum in 10 kg m^2/s, throttle in 100 %.
The sole-corner positions and the net wrench are variables too (tied to the kinematics at the
same knot), so that every interval constraint involves two knots' variables only and no
kinematics: the Hessian is then a sum of small per-knot blocks (see problem.py).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from motionkit.trajopt.kinematics import GRAVITY

THRUST_UNIT = 100.0  # N (and N/s for the thrust rate)
MOMENTUM_UNIT = 10.0  # kg m^2/s (and N m for the net moment)
THROTTLE_UNIT = 100.0  # %


@dataclass(frozen=True)
class Block:
    name: str
    start: int
    size: int
    scale: float

    @property
    def slice(self) -> slice:
        return slice(self.start, self.start + self.size)


class KnotLayout:
    """State (pose, centroidal momentum, jets) then inputs (velocities, forces, throttle)."""

    def __init__(self, joints: int, corners: int, jets: int, mass: float) -> None:
        self.joints, self.corners, self.jets, self.mass = joints, corners, jets, mass
        self.force_unit = mass * GRAVITY / corners
        sizes = (
            ("base_position", 3, 1.0),
            ("base_quaternion", 4, 1.0),
            ("joints", joints, 1.0),
            ("com", 3, 1.0),
            ("com_velocity", 3, 1.0),
            ("angular_momentum", 3, MOMENTUM_UNIT),
            ("thrust", jets, THRUST_UNIT),
            ("thrust_rate", jets, THRUST_UNIT),
            ("corners", 3 * corners, 1.0),
            ("net_force", 3, mass * GRAVITY),
            ("net_moment", 3, MOMENTUM_UNIT),
            ("base_velocity", 3, 1.0),
            ("base_angular_velocity", 3, 1.0),
            ("joint_velocities", joints, 1.0),
            ("forces", 3 * corners, self.force_unit),
            ("throttle", jets, THROTTLE_UNIT),
        )
        self.blocks: dict[str, Block] = {}
        start = 0
        for name, size, scale in sizes:
            self.blocks[name] = Block(name, start, size, scale)
            start += size
        self.size = start

    def __getitem__(self, name: str) -> slice:
        return self.blocks[name].slice

    @property
    def q(self) -> slice:
        """The configuration (base position, quaternion, joints): contiguous, unscaled."""
        return slice(0, 7 + self.joints)

    @property
    def nu(self) -> slice:
        """The velocity (base linear, base angular, joints; world frame): contiguous, unscaled."""
        start = self.blocks["base_velocity"].start
        return slice(start, start + 6 + self.joints)

    def scales(self) -> np.ndarray:
        out = np.ones(self.size)
        for block in self.blocks.values():
            out[block.slice] = block.scale
        return out

    def unpack(self, values: np.ndarray) -> dict[str, np.ndarray]:
        """Physical values per block from scaled knot columns (size x N) -> (N, block size)."""
        values = np.asarray(values).reshape(self.size, -1)
        return {name: (values[b.slice] * b.scale).T.copy() for name, b in self.blocks.items()}
