"""The physics of a clip: what the robot's joints, feet and jets must do to perform it.

Inverse dynamics along the clip (pinocchio, floating base) gives the external wrench the motion
needs. Less the jets' thrust, that is what the ground must supply: its centre of pressure (CoP)
must lie in the support polygon of the feet in contact, its force in the friction pyramid. The
contact forces are the clip's own (trajopt clips carry them per sole corner) or else the least-
squares split over the loaded sole corners within friction pyramids; what they cannot supply is
the residual. Joint torques follow from those forces and are compared with the effort limits.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields
from functools import cached_property
from pathlib import Path
from typing import Any

import numpy as np
from scipy.optimize import nnls
from scipy.spatial import ConvexHull, QhullError

from motionkit.core.checks import check
from motionkit.core.errors import DatasetError
from motionkit.core.extras import require
from motionkit.core.filters import low_pass
from motionkit.core.tomlfile import load, read_toml
from motionkit.dataset.trajectory import Trajectory
from motionkit.robot import Robot
from motionkit.robot.geometry import Array, to_rotation
from motionkit.robot.spec import THRUST_AXIS

GRAVITY = 9.81  # m/s^2, as in MuJoCo and pinocchio (the trajopt's 9.80665 differs by 0.03 %)
# Moments are weighed against forces at this lever [m] in the least-squares split and the
# residual: a 10 cm CoP error at full body weight weighs as much as the whole weight.
LEVER = 0.1
# A corner of a clip with contact forces is loaded above this normal force [body weights].
LOADED = 1e-3
ON_EDGE = 1e-3  # m: a CoP this close outside the support counts as on its edge (inside)
# The CoP and friction use count on frames whose ground force is at least this [body weights]:
# below it (a foot that barely touches) the CoP is not defined to the millimetre.
MIN_GROUND_LOAD = 0.02
SPLIT_REGULARISATION = 1e-4  # (body weights)^2: spreads the load where the split is not unique


@dataclass(frozen=True)
class PhysicsConfig:
    """Settings of the check and the thresholds `dataset validate` warns at."""

    friction: float = 0.33  # friction coefficient of the pyramids (the trajopt's setting)
    cop_margin: float = 0.0  # m: the CoP counts as inside when this far inside the support
    residual_tolerance: float = 0.02  # body weights: a frame's residual above this is unexplained
    # Velocities are low-passed at this cut-off [Hz] before they are differentiated (zero-phase
    # Butterworth; 0: off), as inverse dynamics of mocap usually is: IK jitter at the capture
    # rate would otherwise dominate the accelerations.
    smoothing_hz: float = 6.0
    # "central": accelerations by central differences; "forward": (v[k+1] - v[k]) / dt and the
    # base wrench from the forward difference of the centroidal momentum: the explicit Euler
    # steps of a trajectory optimisation's knots (their own discretisation; the last knot,
    # which starts no step, is left out).
    differences: str = "central"
    # Without the clip's own contact forces, a sole corner at most this high [m] above the
    # floor (z = 0) can be loaded; one faster than contact_speed [m/s] horizontally slides, and
    # its friction opposes the slip (a scuffing toe brakes). The clip's contact flags are not
    # used.
    contact_height: float = 0.005
    contact_speed: float = 0.1
    # dataset validate warns when a clip falls short of these shares (0..1)
    min_cop_inside_share: float = 0.9  # of frames whose ground carries a load (MIN_GROUND_LOAD)
    min_torque_within_share: float = 0.9  # of all frames
    min_friction_within_share: float = 0.9  # of the same frames
    min_explained_share: float = 0.9  # frames whose residual is within residual_tolerance

    def __post_init__(self) -> None:
        check(self, DatasetError, ("central", "forward"), "differences")
        check(self, DatasetError, "> 0", "friction")
        check(self, DatasetError, ">= 0", "cop_margin", "residual_tolerance", "smoothing_hz")
        check(self, DatasetError, ">= 0", "contact_height", "contact_speed")
        shares = [item.name for item in fields(self) if item.name.endswith("_share")]
        check(self, DatasetError, "in [0, 1]", *shares)

    @classmethod
    def from_toml(cls, path: Path) -> PhysicsConfig:
        """A TOML file of this config's keys (the others keep their defaults)."""
        return load(cls, read_toml(path, "physics config", DatasetError), str(path), DatasetError)


@dataclass(frozen=True)
class PhysicsReport:
    """Per-frame figures of one clip (arrays over frames) and their summary."""

    joint_names: tuple[str, ...]
    torques: Array  # (T, J) N m, spec order
    effort: Array  # (J,) N m
    contacts: Array  # (T, feet) bool: the feet with a loaded corner
    com: Array  # (T, 3) centre of mass [m, world]
    cop: Array  # (T, 2) world x, y [m] of the needed ground wrench's CoP; NaN without contact
    support: tuple[Array, ...]  # per frame (corners, 2): x, y [m] of the loaded sole corners
    support_distance: Array  # (T,) m, > 0 inside the support polygon; NaN without contact
    friction_ratio: Array  # (T,) max(|f_x|, |f_y|) / (mu f_z) of the needed ground force (the
    # friction pyramid, world axes, as the trajopt's and the split's); inf if f_z <= 0
    residual_force: Array  # (T,) N: needed minus supplied (contacts + thrust) base force
    residual_moment: Array  # (T,) N m, about the centre of mass
    weight: float  # N
    forces_from: str  # "clip" or "least squares"
    config: PhysicsConfig

    @cached_property
    def torque_ratio(self) -> Array:
        return np.abs(self.torques) / self.effort

    @property
    def single_support(self) -> Array:
        return self.contacts.sum(axis=1) == 1

    @property
    def loaded(self) -> Array:
        """(T,) bool: frames whose ground force is large enough for a CoP (see MIN_GROUND_LOAD)."""
        return ~np.isnan(self.support_distance)

    @property
    def cop_inside(self) -> Array:
        """(T,) bool: the CoP inside the support by the margin (False without contact)."""
        distance = np.nan_to_num(self.support_distance, nan=-np.inf)
        return distance >= self.config.cop_margin - ON_EDGE

    @property
    def explained(self) -> Array:
        """(T,) bool: contacts and thrust supply the needed base wrench within tolerance."""
        tolerance = self.config.residual_tolerance * self.weight
        return (self.residual_force <= tolerance) & (self.residual_moment <= tolerance * LEVER)

    def summary(self) -> dict[str, Any]:
        """JSON-ready figures: what retarget and trajopt store in a clip's metrics."""
        frames = len(self.torques)
        contact, single = self.loaded, self.single_support & self.loaded
        worst_frame = self.torque_ratio.max(axis=1)
        over = self.torque_ratio > 1
        worst_joint = int(np.argmax(np.percentile(self.torque_ratio, 90, axis=0)))
        outside = np.clip(-np.nan_to_num(self.support_distance[contact]), 0, None)
        friction = self.friction_ratio[contact]
        figures: dict[str, Any] = {
            "frames": frames,
            "contact_frames": int(contact.sum()),
            "single_support_frames": int(single.sum()),
            "forces_from": self.forces_from,
            "torque_within_share": _share(~over.any(axis=1)),
            "torque_within_share_single_support": _share(~over.any(axis=1)[single]),
            "torque_ratio_p50": _round(np.percentile(worst_frame, 50)),
            "torque_ratio_p90": _round(np.percentile(worst_frame, 90)),
            "torque_ratio_max": _round(worst_frame.max()),
            "worst_joint": self.joint_names[worst_joint],
            "worst_joint_over_share": _share(over[:, worst_joint]),
            "cop_inside_share": _share(self.cop_inside[contact]),
            "cop_inside_share_single_support": _share(self.cop_inside[single]),
            "cop_outside_p95_m": _round(np.percentile(outside, 95)) if outside.size else 0.0,
            "friction_within_share": _share(friction <= 1),
            "friction_use_p95": _round(np.percentile(np.minimum(friction, 1e3), 95))
            if friction.size
            else 0.0,
            "explained_share": _share(self.explained),
            "residual_force_p95_bw": _round(np.percentile(self.residual_force, 95) / self.weight),
            "residual_force_max_bw": _round(self.residual_force.max() / self.weight),
            "residual_moment_p95_nm": _round(np.percentile(self.residual_moment, 95)),
        }
        return figures

    def warnings(self) -> list[str]:
        """The thresholds of the config this clip falls short of, one line each."""
        figures, config = self.summary(), self.config
        lines = []
        for figure, least in (
            ("cop_inside_share", config.min_cop_inside_share),
            ("torque_within_share", config.min_torque_within_share),
            ("friction_within_share", config.min_friction_within_share),
            ("explained_share", config.min_explained_share),
        ):
            if figures[figure] is not None and figures[figure] < least:
                lines.append(f"{figure} = {figures[figure]:.3f} (want >= {least})")
        return lines


def _share(mask: Array) -> float | None:
    return round(float(np.mean(mask)), 4) if mask.size else None


def _round(value: float) -> float:
    return round(float(value), 5)


class RobotDynamics:
    """The robot as a pinocchio floating-base model, with the frames the check needs."""

    def __init__(self, robot: Robot) -> None:
        require("ik", "the physics check", DatasetError, ("pinocchio",))
        import pinocchio as pin

        self.pin, self.robot = pin, robot
        model = robot.model.copy()
        for link in model.links.values():
            link.visuals, link.collisions = [], []
        self.model = pin.buildModelFromXML(model.to_urdf(), pin.JointModelFreeFlyer())
        self.data = self.model.createData()
        joints = [self.model.joints[self.model.getJointId(n)] for n in robot.joint_names]
        self.q_index = np.array([j.idx_q for j in joints])
        self.v_index = np.array([j.idx_v for j in joints])
        self.corner_frames = [
            [self.model.getFrameId(c) for c in foot.corners] for foot in robot.spec.feet
        ]
        self.jet_frames = [self.model.getFrameId(jet.frame) for jet in robot.spec.jets]
        self.mass = float(sum(inertia.mass for inertia in self.model.inertias))

    def configurations(
        self, trajectory: Trajectory, smoothing_hz: float = 0.0, differences: str = "central"
    ) -> tuple[Array, Array, Array]:
        """pinocchio q, v (base velocities in the base frame) and a (their time derivatives,
        of v low-passed at `smoothing_hz`, by central or forward differences)."""
        frames = trajectory.frames
        rotation = to_rotation(trajectory.base_orientation.astype(float))
        q = np.zeros((frames, self.model.nq))
        q[:, :3] = trajectory.base_position
        q[:, 3:7] = rotation.as_quat()  # x, y, z, w
        q[:, self.q_index] = trajectory.joint_positions
        v = np.zeros((frames, self.model.nv))
        v[:, :3] = rotation.inv().apply(trajectory.base_linear_velocity.astype(float))
        v[:, 3:6] = rotation.inv().apply(trajectory.base_angular_velocity.astype(float))
        v[:, self.v_index] = trajectory.joint_velocities
        if frames < 2:
            return q, v, np.zeros_like(v)
        smooth = low_pass(v, trajectory.rate, smoothing_hz)
        if differences == "forward":
            return q, smooth, _forward(smooth, trajectory.time)
        return q, smooth, np.gradient(smooth, trajectory.time, axis=0)

    def momentum_rate(self, q: Array, v: Array, time: Array) -> Array:
        """(T, 6) forward differences of the centroidal momentum (linear; angular about the
        CoM; world axes), the rate that explicit Euler steps of the momentum imply."""
        momentum = np.array(
            [self.pin.computeCentroidalMomentum(self.model, self.data, qk, vk).vector
             for qk, vk in zip(q, v, strict=True)]
        )  # fmt: skip
        return _forward(momentum, time)


def _forward(values: Array, time: Array) -> Array:
    """Forward differences along the first axis, the last one repeated."""
    steps = np.diff(values, axis=0) / np.diff(time)[:, None]
    return np.vstack([steps, steps[-1:]])


_MODELS: dict[tuple[int, str], RobotDynamics] = {}


def _dynamics(robot: Robot) -> RobotDynamics:
    """One pinocchio model per robot and process (building one takes tens of milliseconds)."""
    key = (id(robot), robot.model_hash)
    if key not in _MODELS:
        _MODELS[key] = RobotDynamics(robot)
    return _MODELS[key]


def check_physics(
    trajectory: Trajectory, robot: Robot, config: PhysicsConfig | None = None
) -> PhysicsReport:
    """Inverse dynamics along the clip; see the module docstring."""
    config = config or PhysicsConfig()
    if trajectory.joint_names != robot.joint_names:
        raise DatasetError(
            f"the clip's joints {list(trajectory.joint_names)[:3]}... are not those of "
            f"{robot.name}: cannot check its physics on this robot"
        )
    if len(trajectory.jet_names) != len(robot.spec.jets):
        raise DatasetError(
            f"the clip has {len(trajectory.jet_names)} jets, {robot.name} has "
            f"{len(robot.spec.jets)}"
        )
    for name, values in trajectory.arrays().items():
        if values.dtype != bool and not np.all(np.isfinite(values)):
            raise DatasetError(f"the clip's {name} is not finite: cannot check its physics")
    dynamics = _dynamics(robot)
    clip_forces = None
    if trajectory.contact_forces is not None and robot.spec.feet:
        clip_forces = trajectory.contact_forces.astype(float)
    q, v, a = dynamics.configurations(trajectory, config.smoothing_hz, config.differences)
    momentum_rate = None
    frames = trajectory.frames
    if config.differences == "forward":
        momentum_rate = dynamics.momentum_rate(q, v, trajectory.time)
        frames = max(1, frames - 1)  # the last knot starts no step
    rows = [
        _frame(dynamics, config, q[k], v[k], a[k], trajectory.thrust[k].astype(float),
               None if clip_forces is None else clip_forces[k],
               None if momentum_rate is None else momentum_rate[k])
        for k in range(frames)
    ]  # fmt: skip
    column = {name: np.array([row[name] for row in rows]) for name in rows[0] if name != "support"}
    return PhysicsReport(
        joint_names=robot.joint_names,
        torques=column["torques"],
        effort=robot.limits.effort,
        contacts=column["feet"],
        com=column["com"],
        cop=column["cop"],
        support=tuple(row["support"] for row in rows),
        support_distance=column["support_distance"],
        friction_ratio=column["friction_ratio"],
        residual_force=column["residual_force"],
        residual_moment=column["residual_moment"],
        weight=dynamics.mass * GRAVITY,
        forces_from="clip" if clip_forces is not None else "least squares",
        config=config,
    )


def _frame(
    dynamics: RobotDynamics,
    config: PhysicsConfig,
    q: Array,
    v: Array,
    a: Array,
    thrust: Array,
    clip_forces: Array | None,
    momentum_rate: Array | None = None,
) -> dict[str, Any]:
    """Inverse dynamics of one frame: torques, CoP, friction use and residual. With
    `momentum_rate` (the centroidal wrench the motion needs: force, moment about the CoM, world
    axes), the base rows come from it rather than from the accelerations."""
    pin, model, data = dynamics.pin, dynamics.model, dynamics.data
    needed = pin.rnea(model, data, q, v, a).copy()  # generalised forces; base rows: base frame
    if momentum_rate is not None:
        rotation, base = data.oMi[1].rotation, data.oMi[1].translation
        offset = pin.centerOfMass(model, data, q) - base
        force = momentum_rate[:3] - dynamics.mass * model.gravity.linear
        moment = momentum_rate[3:] + _cross(offset, force)
        needed[:6] = np.concatenate([rotation.T @ force, rotation.T @ moment])
    pin.computeJointJacobians(model, data, q)
    pin.updateFramePlacements(model, data)

    def point_force_map(frame: int) -> tuple[Array, Array]:
        """Position [m, world] of a frame, and J^T (nv, 3) of a world force applied there."""
        jacobian = pin.getFrameJacobian(model, data, frame, pin.LOCAL_WORLD_ALIGNED)
        return data.oMf[frame].translation.copy(), jacobian[:3].T

    for frame, value in zip(dynamics.jet_frames, thrust, strict=True):
        _, transpose = point_force_map(frame)
        force = value * data.oMf[frame].rotation @ np.array(THRUST_AXIS)
        needed -= transpose @ force
    # `needed` is now what the ground must supply: base rows and joint rows
    weight = dynamics.mass * GRAVITY
    corners = [
        (foot, frame) for foot, frames in enumerate(dynamics.corner_frames) for frame in frames
    ]
    if clip_forces is not None:  # the corners the clip loads, with its forces
        flat = clip_forces.reshape(-1, 3)
        chosen = [i for i in range(len(corners)) if flat[i, 2] > LOADED * weight]
        forces = flat[chosen]
        loaded = [point_force_map(corners[i][1]) for i in chosen]
    else:  # the corners on the floor; one that slides pushes with kinetic friction only
        maps = [point_force_map(frame) for _, frame in corners]
        chosen = [i for i, (point, _) in enumerate(maps) if point[2] <= config.contact_height]
        loaded = [maps[i] for i in chosen]
        slips = [(transpose.T @ v)[:2] for _, transpose in loaded]
    feet = np.zeros(len(dynamics.corner_frames), dtype=bool)
    feet[[corners[i][0] for i in chosen]] = True
    rotation, base = data.oMi[1].rotation, data.oMi[1].translation
    com = pin.centerOfMass(model, data, q).copy()
    if clip_forces is None:
        forces = _split(needed[:6], loaded, slips, config, weight)
    for (_, transpose), force in zip(loaded, forces, strict=True):
        needed -= transpose @ force
    residual = needed[:6]  # the base wrench left unexplained, base frame, about the base origin
    force_world = rotation @ residual[:3]
    moment_com = rotation @ residual[3:] - _cross(com - base, force_world)
    torques = needed[dynamics.v_index]
    out: dict[str, Any] = {
        "feet": feet,
        "com": com,
        "torques": torques,
        "residual_force": float(np.linalg.norm(force_world)),
        "residual_moment": float(np.linalg.norm(moment_com)),
        "cop": np.full(2, np.nan),
        "support": np.array([point[:2] for point, _ in loaded]).reshape(-1, 2),
        "support_distance": np.nan,
        "friction_ratio": np.nan,
    }
    if loaded:
        ground = _ground_wrench(forces, loaded, force_world, rotation @ residual[3:], base)
        if np.linalg.norm(ground[0]) >= MIN_GROUND_LOAD * weight:
            out |= _support(ground, loaded, config.friction)
    return out


def _split(
    wrench: Array,
    loaded: list[tuple[Array, Array]],
    slips: list[Array],
    config: PhysicsConfig,
    weight: float,
) -> Array:
    """Forces (corners, 3) [N, world] at the loaded corners whose base wrench is nearest
    `wrench` (least squares, moments weighed at LEVER): each inside its friction pyramid, or,
    for a corner that slides (horizontal velocity in `slips` above contact_speed), along the
    normal tilted against the slip by the friction coefficient (Coulomb's kinetic friction)."""
    if not loaded:
        return np.zeros((0, 3))
    mu = config.friction
    pyramid = np.array([[mu, 0, 1], [-mu, 0, 1], [0, mu, 1], [0, -mu, 1]], dtype=float)
    edges = []
    for slip in slips:
        speed = float(np.linalg.norm(slip))
        if speed > config.contact_speed:
            edges.append(np.array([[*(-mu * slip / speed), 1.0]]))
        else:
            edges.append(pyramid)
    scale = np.array([1, 1, 1, 1 / LEVER, 1 / LEVER, 1 / LEVER]) / weight
    columns = np.concatenate(
        [transpose[:6] @ e.T for (_, transpose), e in zip(loaded, edges, strict=True)], axis=1
    )
    count = columns.shape[1]
    system = np.vstack(
        [columns * scale[:, None], math.sqrt(SPLIT_REGULARISATION) * np.eye(count) / weight]
    )
    target = np.concatenate([wrench * scale, np.zeros(count)])
    weights, _ = nnls(system, target, maxiter=50 * count)
    sizes = np.cumsum([0, *(len(e) for e in edges)])
    return np.array(
        [weights[a:b] @ e for a, b, e in zip(sizes[:-1], sizes[1:], edges, strict=True)]
    )


def _ground_wrench(
    forces: Array, loaded: list[tuple[Array, Array]], force: Array, moment: Array, base: Array
) -> tuple[Array, Array]:
    """The ground wrench the motion needs (force, moment about the world origin): the supplied
    corner forces plus the residual (given at the base origin, world axes)."""
    total_force = forces.sum(axis=0) + force
    points = np.array([point for point, _ in loaded]).reshape(-1, 3)
    total_moment = moment + _cross(base, force) + _cross(points, forces).sum(axis=0)
    return total_force, total_moment


def _cross(a: Array, b: Array) -> Array:
    """Cross products along the last axis (numpy's cross is slow on small arrays)."""
    return np.stack(
        [
            a[..., 1] * b[..., 2] - a[..., 2] * b[..., 1],
            a[..., 2] * b[..., 0] - a[..., 0] * b[..., 2],
            a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0],
        ],
        axis=-1,
    )


def _support(
    ground: tuple[Array, Array], loaded: list[tuple[Array, Array]], friction: float
) -> dict[str, Any]:
    """CoP of the needed ground wrench on the plane of the loaded corners, its signed distance
    to their support polygon, and the friction use of the needed force."""
    force, moment = ground
    points = np.array([point for point, _ in loaded])
    height = float(points[:, 2].mean())
    tangential = float(np.abs(force[:2]).max())  # the pyramid's: |f_x|, |f_y| <= mu f_z
    if force[2] <= 1e-9:  # the ground would have to pull
        return {"friction_ratio": np.inf, "support_distance": -np.inf}
    cop = np.array(
        [(height * force[0] - moment[1]) / force[2], (moment[0] + height * force[1]) / force[2]]
    )
    return {
        "cop": cop,
        "support_distance": polygon_distance(cop, points[:, :2]),
        "friction_ratio": tangential / (friction * force[2]),
    }


def _hull(vertices: Array) -> Array:
    """The convex hull's corners, counter-clockwise; the points themselves when they span no
    area (a segment or a point)."""
    try:
        return vertices[ConvexHull(vertices).vertices]
    except QhullError:
        return vertices


def _nearest_on_boundary(point: Array, hull: Array) -> Array:
    starts, edge = hull, np.roll(hull, -1, axis=0) - hull
    t = np.einsum("ij,ij->i", point - starts, edge) / np.maximum((edge**2).sum(axis=1), 1e-24)
    nearest = starts + np.clip(t, 0, 1)[:, None] * edge
    return nearest[np.argmin(np.linalg.norm(point - nearest, axis=1))]


def _inside(point: Array, hull: Array) -> Array | None:
    """The outward offsets of `point` from the hull's edges; None for a hull without area."""
    if len(hull) < 3:
        return None
    edge = np.roll(hull, -1, axis=0) - hull
    length = np.linalg.norm(edge, axis=1)
    if np.any(length < 1e-12):
        return None
    normal = np.stack([edge[:, 1], -edge[:, 0]], axis=1) / length[:, None]
    return np.einsum("ij,ij->i", point - hull, normal)


def polygon_distance(point: Array, vertices: Array) -> float:
    """Signed distance [m] of a 2-D point to the convex hull of `vertices`: > 0 inside."""
    hull = _hull(vertices)
    offsets = _inside(point, hull)
    if offsets is not None and np.all(offsets <= 0):
        return float(-offsets.max())
    return -float(np.linalg.norm(point - _nearest_on_boundary(point, hull)))


def nearest_in_polygon(point: Array, vertices: Array, margin: float = 0.0) -> Array:
    """The point of the convex hull of `vertices`, shrunk towards its centroid so that its
    edges move in by about `margin` [m], nearest to `point`."""
    hull = _hull(vertices)
    centre = hull.mean(axis=0)
    inradius = polygon_distance(centre, hull)
    if inradius > 0 and margin > 0:
        hull = centre + (hull - centre) * max(0.0, 1.0 - margin / inradius)
    offsets = _inside(point, hull)
    if offsets is not None and np.all(offsets <= 0):
        return point.copy()
    return _nearest_on_boundary(point, hull)
