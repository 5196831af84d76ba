"""The robot's mirror (`motionkit.robot.mirror`) on the trainer's arrays: AMP features chi,
observations and actions, in JAX (any leading axes).

chi blocks: the heading-free base orientation (w, -M v), base linear velocity (M v), base
angular velocity (-M w), joint positions and velocities (partner, sign), end effectors
(partner, M p), thrust (partner jet). The observation is chi's layout (joints relative to the
standing posture, which the mirror maps to itself), then the height map (its rows across the
facing direction reversed; the single base height on flat ground unchanged) and the waypoint
in the base frame (M p). Actions: joint targets (partner, sign), jets (partner).
"""

from __future__ import annotations

import jax.numpy as jnp
import numpy as np

from motionkit.core.errors import RobotModelError, TrainError
from motionkit.dataset.amp import FeatureLayout
from motionkit.robot.mirror import Mirror, robot_mirror
from motionkit.train.env.task import HEIGHT_MAP, Env


class FeatureMirror:
    """The mirror of one layout's chi, observation and action vectors."""

    def __init__(self, mirror: Mirror, layout: FeatureLayout, height_map: tuple[int, int] | None):
        """`height_map`: (points along the facing, across it) of the observation's height map,
        None on flat ground (one height)."""
        self.mirror, self.layout, self.height_map = mirror, layout, height_map
        self.reflection = jnp.asarray(mirror.reflection, jnp.float32)
        self.joints = jnp.asarray(mirror.joints)
        self.signs = jnp.asarray(mirror.joint_signs, jnp.float32)

    def _vectors(self, x: jnp.ndarray, axial: bool = False) -> jnp.ndarray:
        flat = x.reshape(*x.shape[:-1], -1, 3) @ self.reflection.T
        return (-flat if axial else flat).reshape(x.shape)

    def _joint_values(self, q: jnp.ndarray) -> jnp.ndarray:
        return q[..., self.joints] * self.signs

    def chi(self, chi: jnp.ndarray) -> jnp.ndarray:
        """Mirrored AMP features (..., D)."""
        layout, block = self.layout, lambda name: chi[..., self.layout.slice(name)]
        orientation = block("base_orientation")
        effectors = block("end_effectors").reshape(*chi.shape[:-1], -1, 3)
        effectors = effectors[..., np.asarray(self.mirror.effectors), :]
        parts = {
            "base_orientation": jnp.concatenate(
                [orientation[..., :1], self._vectors(orientation[..., 1:], axial=True)], axis=-1
            ),
            "base_linear_velocity": self._vectors(block("base_linear_velocity")),
            "base_angular_velocity": self._vectors(block("base_angular_velocity"), axial=True),
            "joint_position": self._joint_values(block("joint_position")),
            "joint_velocity": self._joint_values(block("joint_velocity")),
            "end_effectors": self._vectors(effectors.reshape(*chi.shape[:-1], -1)),
            "thrust": block("thrust")[..., np.asarray(self.mirror.jets)],
        }
        return layout.join(parts, jnp)

    def obs(self, obs: jnp.ndarray) -> jnp.ndarray:
        """Mirrored observations (..., chi + heights + 3)."""
        size = self.layout.size
        state, heights, waypoint = obs[..., :size], obs[..., size:-3], obs[..., -3:]
        if self.height_map is not None:
            grid = heights.reshape(*heights.shape[:-1], *self.height_map)
            heights = grid[..., ::-1].reshape(heights.shape)
        return jnp.concatenate([self.chi(state), heights, self._vectors(waypoint)], axis=-1)

    def actions(self, actions: jnp.ndarray) -> jnp.ndarray:
        """Mirrored actions (..., joints + jets)."""
        joints = len(self.mirror.joints)
        jets = actions[..., joints:][..., np.asarray(self.mirror.jets)]
        return jnp.concatenate([self._joint_values(actions[..., :joints]), jets], axis=-1)


def feature_mirror(env: Env) -> FeatureMirror:
    """The mirror of an environment's features, observations and actions; TrainError for a
    robot whose names or joint axes have no mirror."""
    try:
        mirror = robot_mirror(env.robot)
    except RobotModelError as exc:
        needs = "[ppo] mirror_coef and [amp] mirror need the robot's mirror"
        raise TrainError(f"{needs}: {exc}") from exc
    height_map = None if env.config.scenario == "flat" else HEIGHT_MAP
    return FeatureMirror(mirror, env.layout, height_map)
