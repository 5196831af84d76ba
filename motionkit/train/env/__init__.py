"""The task: iRonCub walking and flying between waypoints (`task`), its pieces (rewards,
waypoints, terrain, jets) and its physics backends: MJX (`mjx`, JAX or MuJoCo Warp, stepped
inside the jitted rollout) and MuJoCo C (`mujoco`, `mujoco.batch` on the CPU's cores, stepped
between jitted task functions). The task is defined once; a backend only steps the physics and
computes a reset's kinematics."""

from motionkit.train.env.task import HEIGHT_MAP, Env, EnvState, StepInfo, mjcf_text

__all__ = ["HEIGHT_MAP", "Env", "EnvState", "StepInfo", "mjcf_text"]
