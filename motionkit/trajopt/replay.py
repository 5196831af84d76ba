"""Replay of a solution in MuJoCo: joints tracked by the MJCF's PD position actuators, the jets
driven by the planned thrust, base position compared with the plan at every knot.

The plan's explicit-Euler dynamics hold each knot's forces over its interval, so the replay holds
each knot's thrust too (linear interpolation of thrust drifts by half an interval's impulse per
knot). Open loop (`replay`), a flying robot drifts anyway: the error grows over the motion.

`stabilised_replay` adds feedback on the base pose through the thrust: a wrench about the centre
of mass from the base position, velocity, orientation and angular-velocity errors (gains: the
config's [replay] table), mapped onto the jets by least squares (`allocate`) and added to the
planned thrust, which is the feed-forward (with the planned contact forces it makes the plan's
m (a_plan + g)). Its base error says whether a plan is trackable by jets that can only push
along their own axes.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy.interpolate import PchipInterpolator
from scipy.spatial.transform import Rotation, RotationSpline

from motionkit.core.errors import TrajoptError
from motionkit.robot import Robot
from motionkit.robot.geometry import to_rotation
from motionkit.robot.spec import THRUST_AXIS
from motionkit.trajopt.config import Replay
from motionkit.trajopt.kinematics import GRAVITY
from motionkit.trajopt.solve import Solution


def allocate(
    directions: np.ndarray,
    positions: np.ndarray,
    centre: np.ndarray,
    wrench: np.ndarray,
    weights: np.ndarray | None = None,
) -> np.ndarray:
    """The jet thrusts [N] whose force and moment about `centre` best match `wrench` = (force,
    moment) in the least-squares sense, each of the six residuals [N, N m] times `weights`
    (default 1), and the smallest such thrusts where several fit equally: jet j pushes along
    its unit `directions[:, j]` at `positions[:, j]` (3 x J, world)."""
    moments = np.cross(positions - centre[:, None], directions, axis=0)
    matrix = np.vstack([directions, moments])  # 6 x J: the wrench of one newton per jet
    weights = np.ones(6) if weights is None else weights
    thrusts, *_ = np.linalg.lstsq(matrix * weights[:, None], wrench * weights, rcond=None)
    return thrusts


@dataclass(frozen=True)
class Reference:
    """The plan at every physics step: base pose and velocity (shape-preserving cubics through
    the knots and a rotation spline, as in the written clip), joint targets, thrust and the share
    of the weight that the plan puts on the jets."""

    knot: np.ndarray  # (S,) the knot whose interval each step is in
    position: np.ndarray  # (S, 3)
    velocity: np.ndarray  # (S, 3)
    orientation: Rotation  # (S,)
    angular_velocity: np.ndarray  # (S, 3) world frame
    joints: np.ndarray  # (S, joints)
    thrust: np.ndarray  # (S, jets)
    airborne: np.ndarray  # (S,) in [0, 1]


def reference(solution: Solution, mass: float, timestep: float) -> Reference:
    knots, time = solution.knots, solution.time
    substeps = max(1, round(solution.dt / timestep))
    knot = np.repeat(np.arange(len(time) - 1), substeps)
    blend = np.tile(np.arange(substeps) / substeps, len(time) - 1)
    at = time[knot] + blend * solution.dt
    position = PchipInterpolator(time, knots["base_position"], axis=0)
    spline = RotationSpline(time, to_rotation(knots["base_quaternion"]))
    orientation = spline(at)
    joints = knots["joints"]
    # Where the feet carry load the ground holds the robot: base feedback through the jets would
    # only push it against the floor (or lift it before the plan does) and fight the contact.
    # The feedback is scaled by the plan's share of the weight not on the feet, so it fades in
    # over a take-off as the plan unloads the soles and out over a landing as it loads them.
    # Off until the feet are unloaded instead, the jump recipe (whose jets carry most of the
    # weight before lift-off) tipped over and ended 1.4 m off; always on, the figures were
    # about the same as scaled.
    support = knots["forces"][:, 2::3].sum(axis=1) / (mass * GRAVITY)
    return Reference(
        knot=knot,
        position=position(at),
        velocity=position.derivative()(at),
        orientation=orientation,
        angular_velocity=orientation.apply(spline(at, 1)),  # scipy's rate is in the body frame
        joints=(1 - blend)[:, None] * joints[knot] + blend[:, None] * joints[knot + 1],
        thrust=knots["thrust"][knot],  # held over the interval, as in the plan
        airborne=np.clip(1.0 - support[knot], 0.0, 1.0),
    )


class Simulation:
    """The robot's MJCF in MuJoCo, started at the plan's first knot."""

    def __init__(self, solution: Solution, robot: Robot) -> None:
        try:
            import mujoco
        except ImportError as exc:
            raise TrajoptError("the replay check needs MuJoCo: pip install mujoco") from exc
        self.mujoco = mujoco
        knots = solution.knots
        self.model = mujoco.MjModel.from_xml_string(robot.mjcf_text)
        self.data = data = mujoco.MjData(self.model)
        quat = knots["base_quaternion"][0] / np.linalg.norm(knots["base_quaternion"][0])
        data.qpos[:3] = knots["base_position"][0]
        data.qpos[3:7] = quat
        data.qpos[7:] = knots["joints"][0]
        rotation = to_rotation(quat).as_matrix()
        data.qvel[:3] = knots["base_velocity"][0]
        data.qvel[3:6] = rotation.T @ knots["base_angular_velocity"][0]  # body frame
        data.qvel[6:] = knots["joint_velocities"][0]
        mujoco.mj_forward(self.model, data)
        self.joints = len(robot.joint_names)
        self.sites = [self.model.site(jet.frame).id for jet in robot.spec.jets]
        self.t_max = np.array([jet.t_max for jet in robot.spec.jets])
        self.mass = float(self.model.body_mass.sum())

    def step(self, joints: np.ndarray, thrust: np.ndarray) -> None:
        self.data.ctrl[: self.joints] = joints
        self.data.ctrl[self.joints :] = np.clip(thrust, 0.0, self.t_max)
        self.mujoco.mj_step(self.model, self.data)

    def base(self) -> tuple[np.ndarray, np.ndarray, Rotation, np.ndarray]:
        """Base position, linear velocity, orientation and angular velocity (world frame)."""
        qpos, qvel = self.data.qpos, self.data.qvel
        orientation = to_rotation(qpos[3:7])
        return qpos[:3].copy(), qvel[:3].copy(), orientation, orientation.apply(qvel[3:6])

    def jets(self) -> tuple[np.ndarray, np.ndarray]:
        """Thrust directions and nozzle positions (3 x J, world)."""
        frames = self.data.site_xmat[self.sites].reshape(-1, 3, 3)
        return (frames @ np.array(THRUST_AXIS)).T, self.data.site_xpos[self.sites].T

    def centroid(self) -> tuple[np.ndarray, np.ndarray]:
        """The centre of mass and the rotational inertia about it of the whole robot as it
        stands (world frame)."""
        model, data = self.model, self.data
        centre = data.subtree_com[0].copy()
        frames = data.ximat[1:].reshape(-1, 3, 3)
        inertia = np.einsum("bij,bj,bkj->ik", frames, model.body_inertia[1:], frames)
        offset = data.xipos[1:] - centre
        mass = model.body_mass[1:]
        inertia += np.eye(3) * np.sum(mass * np.sum(offset**2, axis=1))
        inertia -= np.einsum("b,bi,bj->ij", mass, offset, offset)
        return centre, inertia


def _feedback(sim: Simulation, ref: Reference, step: int, gains: Replay) -> np.ndarray:
    """The thrust correction [N] of one physics step."""
    share = ref.airborne[step]
    if share <= 0.0:
        return np.zeros(len(sim.sites))
    position, velocity, orientation, omega = sim.base()
    acceleration = gains.position_kp * (ref.position[step] - position)
    acceleration += gains.position_kd * (ref.velocity[step] - velocity)
    error = (ref.orientation[step] * orientation.inv()).as_rotvec()  # world frame
    angular = gains.orientation_kp * error
    angular += gains.orientation_kd * (ref.angular_velocity[step] - omega)
    centre, inertia = sim.centroid()
    wrench = share * np.concatenate([sim.mass * acceleration, inertia @ angular])
    directions, positions = sim.jets()
    weights = np.array([1.0, 1.0, 1.0, 1.0, 1.0, gains.yaw_weight])
    return allocate(directions, positions, centre, wrench, weights)


def _simulate(
    solution: Solution, robot: Robot, gains: Replay | None
) -> tuple[np.ndarray, np.ndarray]:
    """The base position [m] and orientation [rad] errors at every knot, open loop (`gains`
    None) or stabilised."""
    sim = Simulation(solution, robot)
    ref = reference(solution, sim.mass, sim.model.opt.timestep)
    planned = solution.knots["base_position"]
    attitude = to_rotation(solution.knots["base_quaternion"])

    def errors(knot: int) -> tuple[float, float]:
        position, _, orientation, _ = sim.base()
        turn = (attitude[knot] * orientation.inv()).magnitude()
        return float(np.linalg.norm(position - planned[knot])), float(turn)

    found = [errors(0)]
    for step, knot in enumerate(ref.knot):
        thrust = ref.thrust[step]
        if gains is not None:
            thrust = thrust + _feedback(sim, ref, step, gains)
        sim.step(ref.joints[step], thrust)
        if step + 1 == len(ref.knot) or ref.knot[step + 1] != knot:  # at the next knot
            found.append(errors(knot + 1))
    position, orientation = np.array(found).T
    return position, orientation


def _figures(prefix: str, position: np.ndarray, orientation: np.ndarray) -> dict[str, Any]:
    return {
        f"{prefix}_base_error_max_m": float(position.max()),
        f"{prefix}_base_error_final_m": float(position[-1]),
        f"{prefix}_base_error_rms_m": float(np.sqrt(np.mean(position**2))),
        f"{prefix}_base_error_per_knot_m": [round(float(e), 5) for e in position],
        f"{prefix}_orientation_error_max_rad": float(orientation.max()),
    }


def replay(solution: Solution, robot: Robot) -> dict[str, Any]:
    """Simulate the plan open loop; the base position error against it (max, final, RMS) [m]."""
    return _figures("replay", *_simulate(solution, robot, None))


def stabilised_replay(
    solution: Solution, robot: Robot, gains: Replay | None = None
) -> dict[str, Any]:
    """Simulate the plan with base feedback through the jets (gains: the config's by default);
    its base position error (max, final, RMS) [m] and whether the max is within the config's
    `max_base_error` (`stabilised_tracked`)."""
    gains = gains or solution.config.replay
    figures = _figures("stabilised", *_simulate(solution, robot, gains))
    tracked = figures["stabilised_base_error_max_m"] <= gains.max_base_error
    figures["stabilised_tracked"] = bool(tracked)
    return figures
