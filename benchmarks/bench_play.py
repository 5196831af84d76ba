"""`motionkit play`'s loop: the real-time factor (simulated / wall seconds, compilation not
counted) of a 10 s rollout on the training's MuJoCo backend (`mujoco.batch`, one environment),
against the same loop on plain `mujoco.mj_step` and one MjData, in the same run.

    python benchmarks/bench_play.py                  # the paper recipe's actor, untrained
    python benchmarks/bench_play.py --policy runs/tiny

Untrained, the actor of the recipe (paper_gpu: [512, 256, 128]), its output layer's weights
zeroed, gives the action that holds the standing posture: the robot stands for the whole
rollout (a waypoint far away) while the whole network is evaluated. Target: at least 1x real
time.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path
from typing import Any

import jax
import jax.numpy as jnp
import mujoco
import numpy as np

from motionkit import recipes
from motionkit.robot import ironcub
from motionkit.train.config import TrainConfig
from motionkit.train.env.mujoco import READ, Kinematics
from motionkit.train.normalize import RunningNorm
from motionkit.train.play import Player, roll_out
from motionkit.train.policy import Policy, cpu_env, load_policy, policy_env
from motionkit.train.ppo import ActorCritic, actor_params

SECONDS, TARGET = 10.0, 1.0
FAR = np.array([50.0, 0.0, 0.6])


def untrained(recipe: str) -> Policy:
    config = TrainConfig.from_toml(recipes.find("train", recipe))
    env = cpu_env(config, ironcub())
    net = ActorCritic(
        env.action_size,
        config.ppo.actor_hidden,
        config.ppo.critic_hidden,
        config.ppo.action_std(env.num_joints, env.num_jets),
        config.ppo.learn_std,
        tuple(float(a) for a in env.rest_action),
    )
    params = net.init(jax.random.key(0), jnp.zeros((1, env.obs_size)))
    actor = actor_params(params, config.ppo.actor_hidden)
    last = actor["params"][f"Dense_{len(config.ppo.actor_hidden)}"]
    last["kernel"] = jnp.zeros_like(last["kernel"])  # the mean: exactly the rest action
    return Policy(Path(recipe), config, actor, RunningNorm.create(env.obs_size), {}, {})


class PlainPlayer(Player):
    """The baseline: `mj_step` on one MjData, the five arrays the task reads copied out."""

    def reset(self, qpos: np.ndarray, qvel: np.ndarray, thrust: np.ndarray) -> None:
        self.plain = mujoco.MjData(self.model)
        mujoco.mj_resetDataKeyframe(self.model, self.plain, self.model.key("stand").id)
        self.plain.qpos[:], self.plain.qvel[:] = qpos, qvel
        mujoco.mj_kinematics(self.model, self.plain)
        self.data = self.plain
        super().reset(qpos, qvel, thrust)
        self.kinematics = self._kinematics()

    def _kinematics(self) -> Kinematics:
        arrays = {name: getattr(self.plain, name)[None].astype(np.float32) for name in READ}
        arrays["xmat"] = arrays["xmat"].reshape(1, -1, 3, 3)
        return Kinematics(**arrays, batch=np.zeros(1, np.int32))

    def step(self, action: Any) -> None:
        self.jet, self.thrust, ctrl = self.control(action)
        self.plain.ctrl[:] = np.asarray(ctrl)
        mujoco.mj_step(self.model, self.plain, nstep=self.env.config.substeps)
        self.kinematics = self._kinematics()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--policy", type=Path, help="a run or policy folder (default: untrained)")
    parser.add_argument("--recipe", default="paper_gpu", help="of the untrained actor")
    args = parser.parse_args()
    policy = load_policy(args.policy) if args.policy else untrained(args.recipe)
    env = policy_env(policy, ironcub())
    act = policy.act_fn()
    config = env.config
    print(f"actor {list(policy.hidden)}, {config.substeps} substeps at {config.control_hz:g} Hz")
    factors = {}
    for name, kind in (("play (mujoco.batch)", Player), ("baseline (mj_step)", PlainPlayer)):
        player = kind(env)
        tick = time.perf_counter()
        played = roll_out(player, act, [FAR], SECONDS)
        total = time.perf_counter() - tick
        factors[name] = played.real_time_factor
        print(
            f"{name}: {played.seconds:.2f} s simulated (ended {played.end}) in "
            f"{played.wall_seconds:.2f} s: {played.real_time_factor:.1f}x real time; "
            f"compilation {played.compile_seconds:.1f} s (whole call {total:.1f} s)"
        )
    ours = factors["play (mujoco.batch)"]
    ratio = ours / factors["baseline (mj_step)"]
    print(
        f"play: {ours:.1f}x real time, {ratio:.1f}x the baseline's; target >= {TARGET:g}x: "
        f"{'PASS' if ours >= TARGET else 'FAIL'}"
    )


if __name__ == "__main__":
    main()
