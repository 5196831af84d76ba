"""The MJX environment: iRonCub walking and flying between waypoints, pure `reset`/`step`.

One environment is a pytree `EnvState`; `Env.reset(key)` and `Env.step(state, action)` are pure
and jittable; vmap them for a batch. Control at `control_hz` with `substeps` physics steps.
Actions (27) in [-1, 1]: 23 joint position targets (PD in MuJoCo; `action_mapping` "range":
mid-range + action_scale * joint range * a, the AMP reference's; "stand": standing posture +
action_scale * a rad) and 4 jet inputs (`motionkit.train.env.jets`).

Resets: with probability `reset_from_prior` an episode starts in a frame of the motion priors
(reference state initialisation): the frame's base pose moved to the spawn point and turned to
a random heading, its velocities, joints and thrust, and the jet model resting at that thrust;
a start with both soles off the ground gets an air waypoint. Otherwise it starts standing.
Fitted jets start at least at their idle thrust (`Jets.idle`, the steady thrust at the
throttle floor): a walking clip's 0 N is an idling engine.

Observation (all in the base's heading frame or base frame): the blocks of the AMP features
(`motionkit.dataset.amp.FeatureLayout`: heading-free base orientation (4), base linear and
angular velocity (3 + 3), joint positions (23, here relative to standing) and velocities (23),
end effectors relative to the base (4 x 3), thrust (4, here / T_max)), then the height map
(7 x 9 terrain heights at 0.3 m spacing relative to the base; on flat ground the single base
height) and the waypoint relative to the base (3).
The AMP features are those of `motionkit.dataset.amp_features` with the thrust as
`Jets.feature` sees it (above idle, per T_max).
An episode ends when the base is lower than `min_base_height` above the surface below it (a
fall; on a course a hole counts as its rim, so that a fall into a pit is a fall), when the state
is not finite, or after `episode_seconds`; `step` then starts a new one (auto-reset) and reports
the last observation and AMP features of the ended one. A waypoint is replaced when reached or
when its deadline passes (`motionkit.train.env.waypoints`).

The "terrain" scenario runs on a course (`motionkit.train.env.courses`: a tile per level and
kind): each environment keeps a tile (`levels.Tile`) whose level follows the curriculum of
`motionkit.train.env.levels`, starts its episodes on that tile's pad and follows routes across
it (`motionkit.train.env.routes`).
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from dataclasses import replace
from typing import Any

import jax
import jax.numpy as jnp
import mujoco
import numpy as np
from flax import struct

from motionkit.dataset.amp import FeatureLayout
from motionkit.jet_ident.step import GreyBoxThrust, LSTMThrust
from motionkit.robot import Robot
from motionkit.train.amp import PriorData, amp_features
from motionkit.train.config import EnvConfig, RewardConfig
from motionkit.train.devices import resolve_impl
from motionkit.train.env import courses, levels, routes, waypoints
from motionkit.train.env import terrain as terrain_lib
from motionkit.train.env.jets import Jets
from motionkit.train.env.mjx import mjx, put_on_backend
from motionkit.train.env.rewards import swing_reward, task_reward, task_terms
from motionkit.train.spatial import facing_angle, quat_mul, quat_to_matrix

HEIGHT_MAP = (7, 9)  # points along the facing direction x across it
HEIGHT_CELL = 0.3  # m
AIRBORNE_CLEARANCE = 0.05  # m: a sole higher than this above the terrain is off the ground
ROUTE_MARGIN = 1.0  # m kept between waypoints and the terrain's edge


@struct.dataclass
class EnvState:
    data: Any  # mjx.Data (MJX backends) or Kinematics (MuJoCo backend)
    thrust: jax.Array  # (jets,) N
    jet: Any  # jet model state (LSTM (c, h) per jet; () for the ideal jet)
    target: jax.Array  # (3,) current waypoint, world frame
    target_steps: jax.Array  # control steps since the waypoint appeared
    deadline: jax.Array  # control steps it may take
    steps: jax.Array  # control steps in this episode
    reached: jax.Array  # waypoints reached in this episode
    air_reached: jax.Array  # ... of them in the air
    flight_steps: jax.Array  # control steps airborne in a row, up to now
    longest_flight: jax.Array  # the longest such run in this episode
    origin: jax.Array  # the prior transition the episode started from (-1: standing)
    air_share: jax.Array  # chance that a new waypoint is in the air
    prior_share: jax.Array  # chance that a reset starts in a prior frame
    key: jax.Array
    obs: jax.Array
    chi: jax.Array  # AMP features now
    tile: levels.Tile  # the course's tile the episode runs on (level 0, kind 0 on flat ground)
    missed: jax.Array  # waypoints of the route (the first route_waypoints) missed so far


@struct.dataclass
class StepInfo:
    """What one step did, for rewards, learning and evaluation."""

    task_reward: jax.Array
    terms: dict[str, jax.Array]
    done: jax.Array  # the episode ended (fall, non-finite state or time limit)
    truncated: jax.Array  # ... at the time limit
    final_obs: jax.Array  # observation after the step, before any auto-reset
    chi_next: jax.Array  # AMP features after the step, before any auto-reset
    hit: jax.Array  # a waypoint was reached in this step
    timed_out: jax.Array  # a waypoint's deadline passed in this step (it was replaced)
    hit_steps: jax.Array  # control steps the reached waypoint took (0 without a hit)
    approach_speed: jax.Array  # horizontal speed toward the waypoint [m/s]
    airborne: jax.Array  # both soles off the ground after the step
    feet_down: jax.Array  # (feet,) each sole on the ground after the step
    switches: jax.Array  # (feet,) each sole touched down or lifted off in the step
    episode_steps: jax.Array  # steps of the episode so far (its length when done)
    episode_reached: jax.Array  # waypoints reached in the episode so far
    episode_air_reached: jax.Array  # ... of them in the air
    episode_longest_flight: jax.Array  # the most control steps airborne in a row so far
    air_target: jax.Array  # the waypoint pursued in the step is an air one
    prior_reset: jax.Array  # the episode ended and the next one starts in a prior frame
    level: jax.Array  # the level of the episode's tile (0 on flat ground)
    kind: jax.Array  # the index of its kind
    over_hole: jax.Array  # the base is over a pit or a gap after the step
    moved: jax.Array  # horizontal distance the base moved in the step [m]
    route_done: jax.Array  # the route's waypoints were all reached in turn, none missed
    base_lift: jax.Array  # the base's height above the surface after the step [m]


@struct.dataclass
class ResetPose:
    """Where an episode starts, before its kinematics are computed."""

    qpos: jax.Array
    qvel: jax.Array
    thrust: jax.Array  # (jets,) N
    origin: jax.Array  # the prior transition it starts from (-1: standing)
    target: jax.Array  # (3,) its first waypoint
    air_share: jax.Array
    prior_share: jax.Array
    key: jax.Array  # the episode's own key
    tile: levels.Tile


def mjcf_text(robot: Robot, terrain: terrain_lib.Terrain | None) -> str:
    """The robot's MJCF, on the floor plane or on the terrain's heightfield."""
    root = ET.fromstring(robot.mjcf_text)
    if terrain is not None:
        asset_xml, geom_xml = terrain_lib.hfield_mjcf(terrain)
        asset = root.find("asset")
        if asset is None:
            asset = ET.Element("asset")
            root.insert(list(root).index(root.find("worldbody")), asset)
        asset.append(ET.fromstring(asset_xml))
        world = root.find("worldbody")
        floor = world.find("geom[@name='floor']")
        world.remove(floor)
        world.insert(0, ET.fromstring(geom_xml))
    return ET.tostring(root, encoding="unicode")


class Env:
    """iRonCub in MJX with waypoint routes; a plain Python object holding static data.
    `prior`: the motion priors (`motionkit.train.priors.load_priors`) whose frames resets may
    start from; `self.prior` holds them with the environment's thrust features. `worlds`: the
    environments stepped together on one device (sizes MuJoCo Warp's contact buffer).
    `terrain`: a height grid of the course's shape to use instead of the course itself (a
    hand-made course, for tests)."""

    def __init__(
        self,
        robot: Robot,
        config: EnvConfig,
        reward: RewardConfig | None = None,
        jet_model: LSTMThrust | GreyBoxThrust | None = None,
        prior: PriorData | None = None,
        worlds: int = 1,
        terrain: terrain_lib.Terrain | None = None,
    ) -> None:
        config = replace(config, impl=resolve_impl(config.impl))
        self.robot, self.config = robot, config
        self.reward_config = reward or RewardConfig()
        flat = config.scenario == "flat"
        self.course = None if flat else courses.CourseLayout.of(config)
        self.kinds: tuple[str, ...] = () if flat else self.course.kinds
        if terrain is None:
            terrain = terrain_lib.flat() if flat else courses.build(self.course)
        self.terrain = terrain
        model = mujoco.MjModel.from_xml_string(mjcf_text(robot, None if flat else self.terrain))
        model.opt.timestep = config.control_dt / config.substeps
        model.opt.iterations = config.solver_iterations
        model.opt.ls_iterations = config.ls_iterations
        self.mj_model = model
        data = mujoco.MjData(model)
        mujoco.mj_resetDataKeyframe(model, data, model.key("stand").id)
        mujoco.mj_kinematics(model, data)  # no collision: MJX sizes its own contact arrays
        self.stand_qpos = jnp.asarray(data.qpos, jnp.float32)
        self.mx = self.stand = None  # the MuJoCo backend steps the model itself
        if config.impl in ("jax", "warp"):
            self.mx, self.stand = put_on_backend(model, data, config.impl, worlds)

        spec = robot.spec
        joints = len(robot.joint_names)
        self.num_joints, self.num_jets = joints, len(spec.jets)
        self.action_size = joints + self.num_jets
        self.default_q = jnp.asarray(model.key_qpos[0, 7:])
        self.ctrl_low = jnp.asarray(model.actuator_ctrlrange[:joints, 0])
        self.ctrl_high = jnp.asarray(model.actuator_ctrlrange[:joints, 1])
        if config.action_mapping == "range":
            self.action_offset = (self.ctrl_low + self.ctrl_high) / 2
            self.action_scale = config.action_scale * (self.ctrl_high - self.ctrl_low)
        else:
            self.action_offset = self.default_q
            self.action_scale = jnp.full(joints, config.action_scale)
        self.jets = Jets(config, np.array([jet.t_max for jet in spec.jets]), jet_model)
        self.t_max = self.jets.t_max
        standing = jnp.clip((self.default_q - self.action_offset) / self.action_scale, -1, 1)
        # the action that holds the standing posture and the jets: where the policy starts
        self.rest_action = jnp.concatenate(
            [standing, jnp.full(self.num_jets, self.jets.rest_action)]
        )
        self.forward = jnp.asarray(spec.forward)
        site = lambda name: model.site(name).id  # noqa: E731
        self.effector_sites = jnp.array([site(n) for n in spec.end_effectors])
        self.sole_sites = jnp.array([site(foot.sole) for foot in spec.feet])
        self.base_body = model.body(spec.root).id

        self.spawns = jnp.zeros((1, 2))  # flat ground's spawn point (a course's: `tile_centre`)
        self.route_bound = 1e6 if flat else self.course.cells * terrain_lib.CELL / 2 - ROUTE_MARGIN
        grid_x = (np.arange(HEIGHT_MAP[0]) - (HEIGHT_MAP[0] - 1) / 2) * HEIGHT_CELL
        grid_y = (np.arange(HEIGHT_MAP[1]) - (HEIGHT_MAP[1] - 1) / 2) * HEIGHT_CELL
        self.height_points = jnp.asarray(np.stack(np.meshgrid(grid_x, grid_y, indexing="ij"), -1))
        heights = 1 if flat else HEIGHT_MAP[0] * HEIGHT_MAP[1]
        self.layout = FeatureLayout.of(robot)
        self.chi_size = self.layout.size
        self.obs_size = self.layout.size + heights + 3
        self.prior = None if prior is None else self._with_thrust_features(prior)

    def _with_thrust_features(self, prior: PriorData) -> PriorData:
        """The prior with its thrust columns as `Jets.feature`."""
        if prior.current.shape[1] != self.chi_size:
            raise ValueError(
                f"prior features have {prior.current.shape[1]} columns, the environment "
                f"{self.chi_size}"
            )
        thrust = self.layout.slice("thrust")

        def convert(chi: jax.Array) -> jax.Array:
            return chi.at[:, thrust].set(self.jets.feature(chi[:, thrust]))

        return prior.replace(current=convert(prior.current), following=convert(prior.following))

    # -- pieces ---------------------------------------------------------------------------------
    def _effectors(self, data: mjx.Data) -> jax.Array:
        """End effectors relative to the base, in the base frame (E, 3)."""
        base = data.xpos[self.base_body]
        return (data.site_xpos[self.effector_sites] - base) @ data.xmat[self.base_body]

    def _heights(self, data: mjx.Data) -> jax.Array:
        base = data.qpos[:3]
        if self.config.scenario == "flat":
            return jnp.array([base[2] - terrain_lib.height_at(self.terrain, base[:2])])
        yaw = facing_angle(quat_to_matrix(data.qpos[3:7]), self.forward)
        turn = jnp.array([[jnp.cos(yaw), -jnp.sin(yaw)], [jnp.sin(yaw), jnp.cos(yaw)]])
        points = base[:2] + self.height_points @ turn.T
        return (terrain_lib.height_at(self.terrain, points) - base[2]).ravel()

    def _in_layout(self, data: mjx.Data, joints: jax.Array, thrust: jax.Array) -> jax.Array:
        """The state in the AMP feature layout, with these joint and thrust columns."""
        return amp_features(
            self.layout,
            data.qpos[3:7],
            data.qvel[:3],
            data.qvel[3:6],
            joints,
            data.qvel[6:],
            self._effectors(data),
            thrust,
            self.forward,
        )

    def observe(self, data: mjx.Data, thrust: jax.Array, target: jax.Array) -> jax.Array:
        state = self._in_layout(data, data.qpos[7:] - self.default_q, thrust / self.t_max)
        waypoint = quat_to_matrix(data.qpos[3:7]).T @ (target - data.qpos[:3])
        return jnp.concatenate([state, self._heights(data), waypoint])

    def features(self, data: mjx.Data, thrust: jax.Array) -> jax.Array:
        """The AMP features chi of the state (as motionkit.dataset.amp_features, the thrust as
        `Jets.feature`)."""
        return self._in_layout(data, data.qpos[7:], self.jets.feature(thrust))

    def sole_clearance(self, data: mjx.Data) -> jax.Array:
        """(feet,) each sole's height above the terrain below it [m]."""
        soles = data.site_xpos[self.sole_sites]
        return soles[:, 2] - terrain_lib.height_at(self.terrain, soles[:, :2])

    def feet_down(self, data: mjx.Data) -> jax.Array:
        """(feet,) whether each sole is within AIRBORNE_CLEARANCE of the terrain."""
        return self.sole_clearance(data) <= AIRBORNE_CLEARANCE

    def _swing(self, before: Any, data: Any, clearance: jax.Array, target: jax.Array) -> jax.Array:
        """The swing term of the step from `before` to `data` (`rewards.swing_reward`), given
        the soles' clearance after it; 0 on the way to an air waypoint, where steps beneath it
        would pay what a flight to it cannot."""
        moved = data.site_xpos[self.sole_sites, :2] - before.site_xpos[self.sole_sites, :2]
        speed = jnp.linalg.norm(moved, axis=-1) / self.config.control_dt
        down = clearance <= AIRBORNE_CLEARANCE
        config = self.reward_config
        swing = swing_reward(clearance, speed, down, config.swing_height, config.v_desired)
        return jnp.where(waypoints.in_air(self.terrain, target, self.config), 0.0, swing)

    def _ground_thrust(self, thrust: jax.Array, target: jax.Array) -> jax.Array:
        """-mean_j T_j / T_max on the way to a ground waypoint (0 toward an air one): the jets
        idle while the robot walks."""
        usage = jnp.mean(thrust / self.t_max)
        return jnp.where(waypoints.in_air(self.terrain, target, self.config), 0.0, -usage)

    def joint_targets(self, joint_actions: jax.Array) -> jax.Array:
        return jnp.clip(
            self.action_offset + self.action_scale * joint_actions, self.ctrl_low, self.ctrl_high
        )

    # -- reset and step -------------------------------------------------------------------------
    def _standing(self, key: jax.Array, spawn: jax.Array) -> tuple[jax.Array, ...]:
        k_noise, k_thrust = jax.random.split(key)
        noise = self.config.joint_noise
        joints = self.default_q + jax.random.uniform(
            k_noise, (self.num_joints,), minval=-noise, maxval=noise
        )
        joints = jnp.clip(joints, self.ctrl_low, self.ctrl_high)
        qpos = self.stand_qpos.at[:2].add(spawn).at[7:].set(joints)
        if self.course is not None:  # on the ground below the spawn point
            qpos = qpos.at[2].add(terrain_lib.height_at(self.terrain, spawn))
        low, high = self.config.initial_thrust
        thrust = jax.random.uniform(k_thrust, (self.num_jets,), minval=low, maxval=high)
        return qpos, jnp.zeros(self.mj_model.nv), jnp.minimum(thrust, self.t_max)

    def _prior_frame(self, index: jax.Array, key: jax.Array, spawn: jax.Array) -> tuple:
        """(qpos, qvel, thrust, airborne) of prior frame `index`, its base moved above the
        spawn point and turned about z by a random angle."""
        states = self.prior.states
        qpos, qvel = states.qpos[index], states.qvel[index]
        yaw = jax.random.uniform(key, minval=-jnp.pi, maxval=jnp.pi)
        turn = jnp.array([jnp.cos(yaw / 2), 0.0, 0.0, jnp.sin(yaw / 2)])
        cos, sin = jnp.cos(yaw), jnp.sin(yaw)
        vx, vy = qvel[0], qvel[1]
        ground = terrain_lib.height_at(self.terrain, spawn)
        qpos = jnp.concatenate([spawn, qpos[2:3] + ground, quat_mul(turn, qpos[3:7]), qpos[7:]])
        qvel = qvel.at[:2].set(jnp.array([cos * vx - sin * vy, sin * vx + cos * vy]))
        return qpos, qvel, jnp.minimum(states.thrust[index], self.t_max), states.airborne[index]

    @property
    def default_prior_share(self) -> float:
        """The chance that a reset starts in a prior frame: reset_from_prior with priors."""
        has_states = self.prior is not None and self.prior.states is not None
        return self.config.reset_from_prior if has_states else 0.0

    def reset_pose(
        self,
        key: jax.Array,
        air_share: jax.Array | float | None = None,
        prior_share: jax.Array | float | None = None,
        tile: levels.Tile | None = None,
    ) -> ResetPose:
        """Where a new episode starts, before its kinematics. `air_share` (default:
        air_probability): chance of an air waypoint; `prior_share` (default: reset_from_prior
        with priors, else 0): chance to start in a prior frame; `tile` (a course's; default: a
        training environment's first, `levels.first_tile`): where it starts (the middle of
        the tile's pad) and its route runs."""
        config = self.config
        has_states = self.prior is not None and self.prior.states is not None
        if air_share is None:
            air_share = config.air_probability
        if prior_share is None:
            prior_share = self.default_prior_share
        air_share = jnp.asarray(air_share, jnp.float32)
        prior_share = jnp.asarray(prior_share, jnp.float32)
        k_spawn, k_stand, k_target, k_pick, k_use, k_yaw, k_next = jax.random.split(key, 7)
        if self.course is None:
            spawn = self.spawns[jax.random.randint(k_spawn, (), 0, self.spawns.shape[0])]
            tile = self.flat_tile
        else:
            if tile is None:
                top = min(config.max_start_level, self.course.levels - 1)
                kinds, moves = len(self.kinds), config.terrain_curriculum
                tile = levels.first_tile(k_spawn, kinds, top, moves)
            spawn = self.tile_centre(tile)
        qpos, qvel, thrust = self._standing(k_stand, spawn)
        origin, airborne = jnp.array(-1, jnp.int32), jnp.array(False)
        if has_states:
            index = self.prior.sample_index(k_pick, ()).astype(jnp.int32)
            frame = self._prior_frame(index, k_yaw, spawn)
            use = jax.random.uniform(k_use) < prior_share
            qpos, qvel, thrust = (
                jnp.where(use, a, b) for a, b in zip(frame[:3], (qpos, qvel, thrust), strict=True)
            )
            origin = jnp.where(use, index, origin)
            airborne = use & frame[3]
        thrust = jnp.maximum(thrust, self.jets.idle)  # a fitted jet runs at least at idle
        target = self.next_waypoint(
            k_target,
            qpos[:3],
            jnp.where(airborne, 1.0, air_share),
            facing_angle(quat_to_matrix(qpos[3:7]), self.forward),
            tile,
        )
        return ResetPose(qpos, qvel, thrust, origin, target, air_share, prior_share, k_next, tile)

    @property
    def flat_tile(self) -> levels.Tile:
        """The one "tile" of flat ground, held still."""
        return levels.fixed_tile(0, 0)

    def tile_centre(self, tile: levels.Tile) -> jax.Array:
        """(x, y) of the centre of a course's tile [m]."""
        return jnp.stack(courses.tile_centre(self.course, tile.level, tile.kind)).astype(
            jnp.float32
        )

    def evaluation_tile(self, key: jax.Array, fixed: tuple[int, int] | None = None) -> Any:
        """The tile of an evaluation episode, held still: on a course, `fixed` (kind index,
        level) or a random one of the whole course; None on flat ground."""
        if self.course is None:
            return None
        if fixed is not None:
            return levels.fixed_tile(fixed[1], fixed[0])
        return levels.evaluation_tile(key, len(self.kinds), self.course.levels)

    def next_waypoint(
        self,
        key: jax.Array,
        previous: jax.Array,
        air_share: jax.Array,
        heading: jax.Array,
        tile: levels.Tile,
    ) -> jax.Array:
        """The waypoint after `previous`: on flat ground `waypoints.next_waypoint`, on a course
        the route across the tile (`routes.course_waypoint`)."""
        if self.course is None:
            return waypoints.next_waypoint(
                key, previous, self.config, self.terrain, self.route_bound, air_share, heading
            )
        stones = (
            tile.kind == self.kinds.index("stones") if "stones" in self.kinds else jnp.array(False)
        )
        return routes.course_waypoint(
            key,
            previous,
            self.tile_centre(tile),
            self.course.difficulty(tile.level),
            stones,
            self.config,
            self.terrain,
            self.route_bound,
            air_share,
        )

    def start(self, pose: ResetPose, data: Any) -> EnvState:
        """The episode that starts at `pose`, its kinematics `data` (an mjx.Data or the
        MuJoCo backend's `Kinematics`, at pose.qpos)."""
        zero = jnp.array(0, jnp.int32)
        return EnvState(
            data=data,
            thrust=pose.thrust,
            jet=self.jets.state_at(pose.thrust),
            target=pose.target,
            target_steps=zero,
            deadline=self._deadline(pose.qpos[:3], pose.target),
            steps=zero,
            reached=zero,
            air_reached=zero,
            flight_steps=zero,
            longest_flight=zero,
            origin=pose.origin,
            air_share=pose.air_share,
            prior_share=pose.prior_share,
            key=pose.key,
            obs=self.observe(data, pose.thrust, pose.target),
            chi=self.features(data, pose.thrust),
            tile=pose.tile,
            missed=zero,
        )

    def reset(
        self,
        key: jax.Array,
        air_share: jax.Array | float | None = None,
        prior_share: jax.Array | float | None = None,
        tile: levels.Tile | None = None,
    ) -> EnvState:
        """A new episode in MJX (`reset_pose` and its kinematics)."""
        return self._start_mjx(self.reset_pose(key, air_share, prior_share, tile))

    def _start_mjx(self, pose: ResetPose) -> EnvState:
        data = mjx.kinematics(self.mx, self.stand.replace(qpos=pose.qpos, qvel=pose.qvel))
        return self.start(pose, data)

    def _deadline(self, position: jax.Array, target: jax.Array) -> jax.Array:
        return waypoints.deadline_steps(position, target, self.config, self.reward_config.v_desired)

    def _jets(self, state: EnvState, action: jax.Array) -> tuple[Any, jax.Array]:
        return self.jets.step(state.jet, state.thrust, action)

    def control(self, state: EnvState, action: jax.Array) -> tuple[jax.Array, Any, jax.Array]:
        """(ctrl, jet model state, thrust) of `action` from `state`: the action clipped to
        [-1, 1], the PD targets mapped, the jets stepped (the ideal jets' thrust at most
        `thrust_limit` of T_max)."""
        action = jnp.clip(action, -1.0, 1.0)
        jet, thrust = self._jets(state, action[self.num_joints :])
        if self.config.thrust_limit < 1.0:
            thrust = jnp.minimum(thrust, self.config.thrust_limit * self.t_max)
        return jnp.concatenate([self.joint_targets(action[: self.num_joints]), thrust]), jet, thrust

    def advance(
        self, state: EnvState, data: Any, jet: Any, thrust: jax.Array
    ) -> tuple[EnvState, StepInfo, ResetPose]:
        """The task after the physics stepped `state` to `data` (an mjx.Data or the
        MuJoCo backend's `Kinematics`):
        rewards, waypoints, termination, observation. Returns the state stepped (not reset),
        what the step did, and the pose the next episode starts from where info.done."""
        base, velocity = data.qpos[:3], data.qvel[:3]
        facing = quat_to_matrix(data.qpos[3:7]) @ self.forward
        terms = task_terms(
            base, velocity, facing, state.target, thrust, self.t_max, self.reward_config
        )
        clearance = self.sole_clearance(data)
        feet_down = clearance <= AIRBORNE_CLEARANCE
        if self.reward_config.w_swing > 0:
            terms["swing"] = self._swing(state.data, data, clearance, state.target)
        if self.reward_config.w_ground_thrust > 0:
            terms["ground_thrust"] = self._ground_thrust(thrust, state.target)
        reward = task_reward(terms, self.reward_config)
        offset = (state.target - base)[:2]
        approach = jnp.dot(velocity[:2], offset) / (jnp.linalg.norm(offset) + 1e-6)

        key, k_target, k_reset = jax.random.split(state.key, 3)
        hit = waypoints.reached(base, state.target, self.config.waypoint_radius)
        target_steps = state.target_steps + 1
        timed_out = ~hit & (target_steps >= state.deadline)
        new = hit | timed_out
        new_target = self.next_waypoint(
            k_target,
            jnp.where(hit, state.target, base),
            state.air_share,
            jnp.arctan2(facing[1], facing[0]),
            state.tile,
        )
        target = jnp.where(new, new_target, state.target)
        deadline = jnp.where(new, self._deadline(base, new_target), state.deadline)
        steps, reached = state.steps + 1, state.reached + hit.astype(jnp.int32)
        air_target = waypoints.in_air(self.terrain, state.target, self.config)
        air_reached = state.air_reached + (hit & air_target).astype(jnp.int32)
        airborne = ~jnp.any(feet_down)
        flight_steps = jnp.where(airborne, state.flight_steps + 1, 0)
        longest_flight = jnp.maximum(state.longest_flight, flight_steps)

        route = self.config.route_waypoints
        missed = state.missed + (timed_out & (state.reached < route)).astype(jnp.int32)
        route_done = (reached >= route) & (missed == 0)

        finite = jnp.all(jnp.isfinite(data.qpos)) & jnp.all(jnp.isfinite(data.qvel))
        lift = base[2] - terrain_lib.surface_at(self.terrain, base[:2])
        fell = (lift < self.config.min_base_height) | ~finite
        truncated = (steps >= self.config.max_steps) & ~fell
        done = fell | truncated
        obs = self.observe(data, thrust, target)
        chi = self.features(data, thrust)
        tile = state.tile
        if self.course is not None:  # the curriculum: the next episode's level
            up, key_level = (reached >= route) & ~fell, jax.random.fold_in(k_reset, 1)
            tile = levels.next_tile(key_level, tile, up, fell, self.course.levels)
        pose = self.reset_pose(k_reset, state.air_share, state.prior_share, tile)
        info = StepInfo(
            task_reward=jnp.where(finite, reward, 0.0),
            terms=terms,
            done=done,
            truncated=truncated,
            final_obs=jnp.where(finite, obs, 0.0),
            chi_next=jnp.where(finite, chi, 0.0),
            hit=hit,
            timed_out=timed_out,
            hit_steps=jnp.where(hit, target_steps, 0),
            approach_speed=jnp.where(finite, approach, 0.0),
            airborne=airborne,
            feet_down=feet_down,
            switches=feet_down != self.feet_down(state.data),
            episode_steps=steps,
            episode_reached=reached,
            episode_air_reached=air_reached,
            episode_longest_flight=longest_flight,
            air_target=air_target,
            prior_reset=done & (pose.origin >= 0),
            level=state.tile.level,
            kind=state.tile.kind,
            over_hole=terrain_lib.over_hole(self.terrain, base[:2]),
            moved=jnp.linalg.norm(base[:2] - state.data.qpos[:2]),
            route_done=route_done,
            base_lift=jnp.where(finite, lift, 0.0),
        )
        stepped = state.replace(
            data=data,
            thrust=thrust,
            jet=jet,
            target=target,
            target_steps=jnp.where(new, 0, target_steps),
            deadline=deadline,
            steps=steps,
            reached=reached,
            air_reached=air_reached,
            flight_steps=flight_steps,
            longest_flight=longest_flight,
            key=key,
            obs=obs,
            chi=chi,
            missed=missed,
        )
        return stepped, info, pose

    def step(self, state: EnvState, action: jax.Array) -> tuple[EnvState, StepInfo]:
        """One control step in MJX; an episode that ends restarts (auto-reset)."""
        ctrl, jet, thrust = self.control(state, action)
        data = state.data.replace(ctrl=ctrl)
        data = jax.lax.fori_loop(0, self.config.substeps, lambda _, d: mjx.step(self.mx, d), data)
        stepped, info, pose = self.advance(state, data, jet, thrust)
        fresh = self._start_mjx(pose)
        state = jax.tree.map(lambda a, b: jnp.where(info.done, a, b), fresh, stepped)
        return state, info
