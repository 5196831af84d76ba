"""The MJX environment: iRonCub walking and flying between waypoints, pure `reset`/`step`.

One environment is a pytree `EnvState`; `Env.reset(key)` and `Env.step(state, action)` are pure
and jittable; vmap them for a batch. Control at `control_hz` with `substeps` physics steps.
Actions (27) in [-1, 1]: 23 joint position targets (standing posture + action_scale * a, PD in
MuJoCo) and 4 jet inputs (ideal jet: thrust rate a * thrust_rate_max; LSTM: throttle
50 + 50 a %), stepped through `motionkit.jet_ident.step.thrust_next`.

Observation (all in the base's heading frame or base frame):
    heading-free base orientation (4), base linear and angular velocity (3 + 3), joint
    positions relative to standing (23) and velocities (23), end effectors relative to the base
    (4 x 3), thrust / T_max (4), height map (7 x 9 terrain heights at 0.3 m spacing relative to
    the base; on flat ground the single base height), waypoint relative to the base (3).
An episode ends when the base is lower than `min_base_height` above the terrain (a fall), when
the state is not finite, or after `episode_seconds`; `step` then starts a new one (auto-reset)
and reports the last observation and AMP features of the ended one.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from typing import Any

import jax
import jax.numpy as jnp
import mujoco
import numpy as np
from flax import struct
from mujoco import mjx

from motionkit.jet_ident.step import IdealThrust, LSTMThrust, initial_state, thrust_next
from motionkit.robot import Robot
from motionkit.train import terrain as terrain_lib
from motionkit.train import waypoints
from motionkit.train.amp import amp_features
from motionkit.train.config import EnvConfig, RewardConfig
from motionkit.train.rewards import task_reward, task_terms
from motionkit.train.spatial import facing_angle, quat_to_matrix, remove_heading

HEIGHT_MAP = (7, 9)  # points along the facing direction x across it
HEIGHT_CELL = 0.3  # m
AIRBORNE_CLEARANCE = 0.05  # m: a sole higher than this above the terrain is off the ground
ROUTE_MARGIN = 1.0  # m kept between waypoints and the terrain's edge


@struct.dataclass
class EnvState:
    data: mjx.Data
    thrust: jax.Array  # (jets,) N
    jet: Any  # jet model state (LSTM (c, h) per jet; () for the ideal jet)
    target: jax.Array  # (3,) current waypoint, world frame
    steps: jax.Array  # control steps in this episode
    reached: jax.Array  # waypoints reached in this episode
    key: jax.Array
    obs: jax.Array
    chi: jax.Array  # AMP features now


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
    airborne: jax.Array  # both soles off the ground after the step
    feet_down: jax.Array  # (feet,) each sole on the ground after the step
    episode_steps: jax.Array  # steps of the episode so far (its length when done)
    episode_reached: jax.Array  # waypoints reached in the episode so far


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
    """iRonCub in MJX with waypoint routes; a plain Python object holding static data."""

    def __init__(
        self,
        robot: Robot,
        config: EnvConfig,
        reward: RewardConfig | None = None,
        jet_model: LSTMThrust | None = None,
    ) -> None:
        self.robot, self.config = robot, config
        self.reward_config = reward or RewardConfig()
        flat = config.scenario == "flat"
        self.terrain = (
            terrain_lib.flat()
            if flat
            else terrain_lib.mixed(config.terrain_size, config.terrain_seed)
        )
        model = mujoco.MjModel.from_xml_string(mjcf_text(robot, None if flat else self.terrain))
        model.opt.timestep = config.control_dt / config.substeps
        model.opt.iterations = config.solver_iterations
        model.opt.ls_iterations = config.ls_iterations
        self.mj_model = model
        data = mujoco.MjData(model)
        mujoco.mj_resetDataKeyframe(model, data, model.key("stand").id)
        mujoco.mj_kinematics(model, data)  # no collision: MJX sizes its own contact arrays
        self.mx = mjx.put_model(model)
        self.stand = mjx.put_data(model, data)

        spec = robot.spec
        joints = len(robot.joint_names)
        self.num_joints, self.num_jets = joints, len(spec.jets)
        self.action_size = joints + self.num_jets
        self.default_q = jnp.asarray(model.key_qpos[0, 7:])
        self.ctrl_low = jnp.asarray(model.actuator_ctrlrange[:joints, 0])
        self.ctrl_high = jnp.asarray(model.actuator_ctrlrange[:joints, 1])
        self.t_max = jnp.array([jet.t_max for jet in spec.jets])
        self.forward = jnp.asarray(spec.forward)
        site = lambda name: model.site(name).id  # noqa: E731
        self.effector_sites = jnp.array([site(n) for n in spec.end_effectors])
        self.sole_sites = jnp.array([site(foot.sole) for foot in spec.feet])
        self.base_body = model.body(spec.root).id

        if config.jet == "lstm":
            if jet_model is None:
                raise ValueError("jet = 'lstm' needs the fitted LSTM (jet_model)")
            self.jet_steps = max(1, round(config.control_dt / jet_model.dt))
            self.jet_params: IdealThrust | LSTMThrust = jet_model.replace(
                dt=config.control_dt / self.jet_steps
            )
            per_jet = jax.vmap(lambda t: initial_state(self.jet_params, t, jnp.zeros(())))
            self.jet_init = per_jet(jnp.zeros(self.num_jets))
        else:
            self.jet_steps = 1
            self.jet_params = IdealThrust(
                dt=config.control_dt,
                t_max=float(spec.jets[0].t_max),
                rate_max=config.thrust_rate_max,
            )
            self.jet_init = ()
        if flat:
            self.spawns = jnp.zeros((1, 2))
            self.route_bound = 1e6
        else:
            self.spawns = jnp.asarray(terrain_lib.tile_centres(config.terrain_size))
            self.route_bound = config.terrain_size / 2 - ROUTE_MARGIN
        grid_x = (np.arange(HEIGHT_MAP[0]) - (HEIGHT_MAP[0] - 1) / 2) * HEIGHT_CELL
        grid_y = (np.arange(HEIGHT_MAP[1]) - (HEIGHT_MAP[1] - 1) / 2) * HEIGHT_CELL
        self.height_points = jnp.asarray(np.stack(np.meshgrid(grid_x, grid_y, indexing="ij"), -1))
        heights = 1 if flat else HEIGHT_MAP[0] * HEIGHT_MAP[1]
        self.obs_size = 10 + 2 * joints + 3 * len(spec.end_effectors) + self.num_jets + heights + 3
        self.chi_size = 10 + 2 * joints + 3 * len(spec.end_effectors) + self.num_jets

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

    def observe(self, data: mjx.Data, thrust: jax.Array, target: jax.Array) -> jax.Array:
        quat, base = data.qpos[3:7], data.qpos[:3]
        rotation = quat_to_matrix(quat)
        return jnp.concatenate(
            [
                remove_heading(quat, self.forward),
                rotation.T @ data.qvel[:3],
                data.qvel[3:6],
                data.qpos[7:] - self.default_q,
                data.qvel[6:],
                self._effectors(data).ravel(),
                thrust / self.t_max,
                self._heights(data),
                rotation.T @ (target - base),
            ]
        )

    def features(self, data: mjx.Data, thrust: jax.Array) -> jax.Array:
        """The AMP features chi of the state (as motionkit.dataset.amp_features)."""
        return amp_features(
            data.qpos[3:7],
            data.qvel[:3],
            data.qvel[3:6],
            data.qpos[7:],
            data.qvel[6:],
            self._effectors(data),
            thrust,
            self.forward,
        )

    def feet_down(self, data: mjx.Data) -> jax.Array:
        """(feet,) whether each sole is within AIRBORNE_CLEARANCE of the terrain."""
        soles = data.site_xpos[self.sole_sites]
        ground = terrain_lib.height_at(self.terrain, soles[:, :2])
        return soles[:, 2] - ground <= AIRBORNE_CLEARANCE

    # -- reset and step -------------------------------------------------------------------------
    def reset(self, key: jax.Array) -> EnvState:
        k_spawn, k_noise, k_target, k_thrust, k_next = jax.random.split(key, 5)
        spawn = self.spawns[jax.random.randint(k_spawn, (), 0, self.spawns.shape[0])]
        noise = jax.random.uniform(
            k_noise,
            (self.num_joints,),
            minval=-self.config.joint_noise,
            maxval=self.config.joint_noise,
        )
        joints = jnp.clip(self.default_q + noise, self.ctrl_low, self.ctrl_high)
        qpos = self.stand.qpos.at[:2].add(spawn).at[7:].set(joints)
        data = self.stand.replace(qpos=qpos, qvel=jnp.zeros_like(self.stand.qvel))
        data = mjx.kinematics(self.mx, data)
        low, high = self.config.initial_thrust
        thrust = jax.random.uniform(k_thrust, (self.num_jets,), minval=low, maxval=high)
        thrust = jnp.minimum(thrust, self.t_max)
        target = waypoints.next_waypoint(
            k_target, qpos[:3], self.config, self.terrain, self.route_bound
        )
        return EnvState(
            data=data,
            thrust=thrust,
            jet=self.jet_init,
            target=target,
            steps=jnp.array(0, jnp.int32),
            reached=jnp.array(0, jnp.int32),
            key=k_next,
            obs=self.observe(data, thrust, target),
            chi=self.features(data, thrust),
        )

    def _jets(self, state: EnvState, action: jax.Array) -> tuple[Any, jax.Array]:
        if isinstance(self.jet_params, IdealThrust):
            u = action * self.config.thrust_rate_max
        else:
            u = 50.0 + 50.0 * action
        per_jet = jax.vmap(thrust_next, in_axes=(None, 0, 0, 0))
        jet, thrust = state.jet, state.thrust
        for _ in range(self.jet_steps):
            jet, thrust = per_jet(self.jet_params, jet, thrust, u)
        return jet, jnp.clip(thrust, 0.0, self.t_max)

    def step(self, state: EnvState, action: jax.Array) -> tuple[EnvState, StepInfo]:
        action = jnp.clip(action, -1.0, 1.0)
        joints, jets = action[: self.num_joints], action[self.num_joints :]
        targets = jnp.clip(
            self.default_q + self.config.action_scale * joints, self.ctrl_low, self.ctrl_high
        )
        jet, thrust = self._jets(state, jets)
        data = state.data.replace(ctrl=jnp.concatenate([targets, thrust]))
        data = jax.lax.fori_loop(0, self.config.substeps, lambda _, d: mjx.step(self.mx, d), data)

        base, velocity = data.qpos[:3], data.qvel[:3]
        facing = quat_to_matrix(data.qpos[3:7]) @ self.forward
        terms = task_terms(
            base, velocity, facing, state.target, thrust, self.t_max[0], self.reward_config
        )
        reward = task_reward(terms, self.reward_config)

        key, k_target, k_reset = jax.random.split(state.key, 3)
        hit = waypoints.reached(base, state.target, self.config.waypoint_radius)
        new_target = waypoints.next_waypoint(
            k_target, state.target, self.config, self.terrain, self.route_bound
        )
        target = jnp.where(hit, new_target, state.target)
        steps, reached = state.steps + 1, state.reached + hit.astype(jnp.int32)

        finite = jnp.all(jnp.isfinite(data.qpos)) & jnp.all(jnp.isfinite(data.qvel))
        lift = base[2] - terrain_lib.height_at(self.terrain, base[:2])
        fell = (lift < self.config.min_base_height) | ~finite
        truncated = (steps >= self.config.max_steps) & ~fell
        done = fell | truncated
        obs = self.observe(data, thrust, target)
        chi = self.features(data, thrust)
        feet_down = self.feet_down(data)
        info = StepInfo(
            task_reward=jnp.where(finite, reward, 0.0),
            terms=terms,
            done=done,
            truncated=truncated,
            final_obs=jnp.where(finite, obs, 0.0),
            chi_next=jnp.where(finite, chi, 0.0),
            hit=hit,
            airborne=~jnp.any(feet_down),
            feet_down=feet_down,
            episode_steps=steps,
            episode_reached=reached,
        )
        stepped = EnvState(data, thrust, jet, target, steps, reached, key, obs, chi)
        fresh = self.reset(k_reset)
        state = jax.tree.map(lambda a, b: jnp.where(done, a, b), fresh, stepped)
        return state, info
