"""The learner: PPO composed with adversarial motion priors (`motionkit.train.style`: the
discriminator, its replay and the style reward as one part). One rollout, then one jitted
update (style rewards, GAE, PPO epochs over minibatches, then discriminator steps on prior
transitions against the policy's, half from this rollout and half from the replay buffer).
The rollout is one jitted `lax.scan` over the vmapped environment on MJX, and a host loop
around jitted policy and task steps on MuJoCo C (`motionkit.train.env.mujoco`).

    trainer = Trainer(config, env)        # env.prior: PriorData or None (no style reward)
    learner, carry = trainer.init(seed)
    learner, carry, metrics = trainer.iteration(learner, carry)

On several devices (`[run] devices`, `motionkit.train.devices`) the environments are split
over a 1-D mesh: the rollout runs per device (`shard_map`, the action noise drawn for the
whole batch first, so that any split draws the same), the update under `jit` on the split
batch with the learner replicated; a minibatch is split over the devices too, so each
gradient is the mean of the devices' parts. Seeded runs agree with one device to float
rounding.
"""

from __future__ import annotations

import time
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np
import optax
from flax import struct
from jax.sharding import Mesh
from jax.sharding import PartitionSpec as P

from motionkit.core.errors import TrainError
from motionkit.train.amp import PriorData, ReplayBuffer
from motionkit.train.config import TrainConfig
from motionkit.train.devices import AXIS, batch_sharding, make_mesh, replicated
from motionkit.train.env import Env, EnvState, StepInfo
from motionkit.train.env.mujoco import BatchPhysics
from motionkit.train.env.rewards import total_reward
from motionkit.train.env.waypoints import air_share
from motionkit.train.figures import rollout_figures
from motionkit.train.normalize import RunningNorm
from motionkit.train.ppo import (
    ActorCritic,
    adapt_learning_rate,
    gae,
    gaussian_kl,
    log_prob,
    mirror_loss,
    ppo_loss,
)
from motionkit.train.style import AdversarialStyle
from motionkit.train.symmetry import feature_mirror


@struct.dataclass
class Learner:
    """Everything that is learned (the checkpoint)."""

    policy: Any
    policy_opt: Any
    learning_rate: jax.Array
    disc: Any
    disc_opt: Any
    obs_norm: RunningNorm
    amp_norm: RunningNorm
    iteration: jax.Array
    env_steps: jax.Array


@struct.dataclass
class Carry:
    """What a run carries between iterations besides the learner (not checkpointed)."""

    env: EnvState
    buffer: ReplayBuffer
    key: jax.Array


@struct.dataclass
class Rollout:
    """Time-major (T, N, ...) arrays of one rollout; `last_obs` (N, obs) after it."""

    obs: jax.Array
    actions: jax.Array
    means: jax.Array
    log_stds: jax.Array
    log_probs: jax.Array
    values: jax.Array
    final_values: jax.Array
    chi: jax.Array
    info: StepInfo  # what each step did
    qpos: jax.Array  # after the step (and its auto-reset)
    qvel: jax.Array
    thrust: jax.Array
    target: jax.Array  # the waypoint pursued during the step
    last_obs: jax.Array


class PhaseClock:
    """Wall seconds spent in each phase of the MuJoCo backend's rollout, summed until read:
    "policy" (the policy and the controls), "physics" (the Batch's step), "task" (rewards,
    waypoints, termination, the record) and "resets" (the ended environments' restarts). A
    phase ends when its result is on the host, so JAX's asynchronous work is counted where it
    ran."""

    def __init__(self) -> None:
        self.seconds: dict[str, float] = {}
        self._mark = time.perf_counter()

    def start(self) -> None:
        self._mark = time.perf_counter()

    def lap(self, phase: str, result: Any) -> Any:
        jax.block_until_ready(result)
        now = time.perf_counter()
        self.seconds[phase] = self.seconds.get(phase, 0.0) + now - self._mark
        self._mark = now
        return result

    def read(self) -> dict[str, float]:
        """The sums so far, then zero."""
        seconds, self.seconds = self.seconds, {}
        return seconds


class Trainer:
    def __init__(self, config: TrainConfig, env: Env, mesh: Mesh | None = None) -> None:
        """`mesh`: the devices to train on (default: `make_mesh` of `[run] devices`)."""
        self.config, self.env = config, env
        if mesh is None:
            mesh = make_mesh(config.run.devices, config.ppo.num_envs)
        self.mesh = mesh
        self.devices = self.mesh.size
        self.prior = self.replicate(env.prior)
        prior: PriorData | None = env.prior
        ppo = config.ppo
        self.net = ActorCritic(
            env.action_size,
            ppo.actor_hidden,
            ppo.critic_hidden,
            ppo.action_std(env.num_joints, env.num_jets),
            ppo.learn_std,
            tuple(float(a) for a in env.rest_action),
            ppo.mean_init_scale,
        )
        self.style = AdversarialStyle(config.amp, ppo.epochs * ppo.minibatches)
        self.policy_tx = optax.chain(
            optax.clip_by_global_norm(ppo.max_grad_norm), optax.scale_by_adam()
        )
        self.use_style = prior is not None and config.reward.w_style > 0
        self.mirror = feature_mirror(env) if ppo.mirror_coef > 0 or config.amp.mirror else None
        if env.config.impl == "mujoco":
            self._init_mujoco()
        else:
            self.reset = self._split_reset(env.reset)
            self._evaluation_resets: dict[float, Any] = {}
            self.rollout = jax.jit(self._rollout)
        kept = replicated(self.mesh)
        self.update = jax.jit(self._update, out_shardings=(kept, kept, kept))

    def _init_mujoco(self) -> None:
        """The MuJoCo backend: one Batch for training and one for evaluations (each holds the
        physics of the states it made), on every core this process may use."""
        if self.devices != 1:
            raise TrainError("[env] impl = 'mujoco' runs on one host: [run] devices must be 1")
        n = self.config.ppo.num_envs
        self.physics = [BatchPhysics(self.env, n, index=k) for k in range(2)]
        self.reset = self.physics[0].reset
        self.clock = PhaseClock()
        self._draws = jax.jit(self._draws_fn, static_argnums=1)
        self._act_control = jax.jit(self._act_control_fn)
        self._advance_record = jax.jit(self._advance_record_fn)
        self._stack = jax.jit(self._stack_fn)
        self.rollout = self._rollout_mujoco

    def reset_evaluation(
        self, keys: jax.Array, prior_share: float = 0.0, tile: tuple[int, int] | None = None
    ) -> EnvState:
        """The starts of an evaluation, one per key: standing, or in a prior frame at
        `prior_share`; with the task's share of air waypoints. On a course every robot starts
        on `tile` (kind index, level), or on a random tile of the whole course (None); the
        tiles hold still (no curriculum)."""
        env, air = self.env, self.env.config.air_probability
        tiles = None
        if env.course is not None:
            pick = lambda key: env.evaluation_tile(jax.random.fold_in(key, 2), tile)  # noqa: E731
            tiles = jax.vmap(pick)(keys)
        if env.config.impl == "mujoco":
            return self.physics[1].reset(keys, air, prior_share, tiles)
        if prior_share not in self._evaluation_resets:
            starts = lambda pair: env.reset(pair[0], air, prior_share, pair[1])  # noqa: E731
            self._evaluation_resets[prior_share] = self._split_reset(starts)
        return self._evaluation_resets[prior_share]((keys, tiles))

    def _split_reset(self, reset: Any) -> Any:
        """`reset` of one environment as a jitted batch reset of keys (or of a pytree of
        per-environment inputs) split over the mesh."""
        batch = jax.shard_map(
            jax.vmap(reset), mesh=self.mesh, in_specs=P(AXIS), out_specs=P(AXIS), check_vma=False
        )
        split = batch_sharding(self.mesh)
        return jax.jit(lambda keys: batch(jax.device_put(keys, split)))

    # -- setup ----------------------------------------------------------------------------------
    def init(self, seed: int) -> tuple[Learner, Carry]:
        key = jax.random.key(seed)
        k_policy, k_disc, k_env, k_run = jax.random.split(key, 4)
        env, ppo = self.env, self.config.ppo
        policy = self.net.init(k_policy, jnp.zeros((1, env.obs_size)))
        disc, disc_opt = self.style.init(k_disc, env.chi_size)
        learner = Learner(
            policy=policy,
            policy_opt=self.policy_tx.init(policy),
            learning_rate=jnp.array(ppo.learning_rate),
            disc=disc,
            disc_opt=disc_opt,
            obs_norm=RunningNorm.create(env.obs_size),
            amp_norm=RunningNorm.create(env.chi_size),
            iteration=jnp.array(0),
            env_steps=jnp.array(0.0),
        )
        return self.replicate(learner), self.new_carry(k_env, k_run)

    def jets_at_rest(self, learner: Learner) -> Learner:
        """`learner` with its policy's jet outputs at the environment's rest action (the mean
        layer's jet columns of weights zero, their bias the rest action), and fresh policy
        optimiser moments: a policy trained with another jet action starts with its jets at
        rest and keeps the rest of what it learned."""
        env, layers = self.env, dict(learner.policy["params"])
        name = f"Dense_{len(self.config.ppo.actor_hidden)}"
        jets = slice(env.num_joints, env.action_size)
        mean = dict(layers[name])
        mean["kernel"] = mean["kernel"].at[:, jets].set(0.0)
        mean["bias"] = mean["bias"].at[jets].set(env.rest_action[jets])
        layers[name] = mean
        policy = dict(learner.policy) | {"params": layers}
        return learner.replace(policy=policy, policy_opt=self.policy_tx.init(policy))

    def replicate(self, tree: Any) -> Any:
        """`tree` (a learner, a replay buffer) on every device of the mesh."""
        return jax.device_put(tree, replicated(self.mesh))

    def new_carry(self, k_env: jax.Array, k_run: jax.Array) -> Carry:
        n = self.config.ppo.num_envs
        buffer = ReplayBuffer.create(self.config.amp.buffer_size, self.env.chi_size)
        state = self.reset(jax.random.split(k_env, n))
        return Carry(state, self.replicate(buffer), self.replicate(k_run))

    # -- rollout --------------------------------------------------------------------------------
    def _rollout(
        self, learner: Learner, state: EnvState, key: jax.Array, noise: jax.Array
    ) -> tuple[EnvState, Rollout]:
        """rollout_steps steps of every environment; actions mean + noise * std * N(0, 1)
        (noise 1 to learn, 0 to evaluate). The N(0, 1) draws are made for the whole batch,
        split over the devices like the environments, then each device steps its part."""
        normal = jax.lax.with_sharding_constraint(
            self._draws_fn(key, state.obs.shape[0]), batch_sharding(self.mesh, 1)
        )
        steps = jax.shard_map(
            self._steps,
            mesh=self.mesh,
            in_specs=(P(), P(AXIS), P(None, AXIS), P()),
            out_specs=(P(AXIS), P(None, AXIS)),
            check_vma=False,  # MJX's solver loops are not written for shard_map's type checks
        )
        state, records = steps(learner, state, normal, noise)
        return state, Rollout(**records, last_obs=state.obs)

    def _draws_fn(self, key: jax.Array, envs: int) -> jax.Array:
        """The rollout's N(0, 1) action draws, (T, envs, actions)."""
        shape = (envs, self.env.action_size)
        draw = lambda k: jax.random.normal(k, shape)  # noqa: E731
        return jax.vmap(draw)(jax.random.split(key, self.config.ppo.rollout_steps))

    def _steps(
        self, learner: Learner, state: EnvState, normal: jax.Array, noise: jax.Array
    ) -> tuple[EnvState, dict[str, Any]]:
        """The rollout of one device's environments, given their N(0, 1) draws (T, n, A)."""
        step = jax.vmap(self.env.step)

        def one(state: EnvState, z: jax.Array) -> tuple[EnvState, dict[str, Any]]:
            acted = self._act(learner, state.obs, z, noise)
            after, info = step(state, acted["actions"])
            return after, self._record(learner, state, acted, info, after)

        return jax.lax.scan(one, state, normal)

    def _act(
        self, learner: Learner, obs: jax.Array, z: jax.Array, noise: jax.Array
    ) -> dict[str, jax.Array]:
        """The policy at `obs`: actions mean + noise * std * z, their log-probabilities, values."""
        mean, log_std, value = self.net.apply(learner.policy, learner.obs_norm(obs))
        action = mean + noise * jnp.exp(log_std) * z
        return {
            "obs": obs,
            "actions": action,
            "means": mean,
            "log_stds": log_std,
            "log_probs": log_prob(mean, log_std, action),
            "values": value,
        }

    def _record(
        self, learner: Learner, before: EnvState, acted: dict, info: StepInfo, after: EnvState
    ) -> dict[str, Any]:
        """One step's row of the Rollout."""
        _, _, final_value = self.net.apply(learner.policy, learner.obs_norm(info.final_obs))
        return acted | {
            "final_values": final_value,
            "chi": before.chi,
            "info": info,
            "qpos": after.data.qpos,
            "qvel": after.data.qvel,
            "thrust": after.thrust,
            "target": before.target,
        }

    # -- rollout on the MuJoCo backend ------------------------------------------------------------
    def _rollout_mujoco(
        self, learner: Learner, state: EnvState, key: jax.Array, noise: jax.Array
    ) -> tuple[EnvState, Rollout]:
        """`_rollout` with the physics in MuJoCo C: per control step, one jitted call for the
        policy and the controls, the Batch's step on all cores, one jitted call for the task
        and the record, then the resets of the environments whose episode ended."""
        physics = self.physics[int(state.data.batch[0])]
        normal = self._draws(key, state.obs.shape[0])
        rows, clock = [], self.clock
        for z in normal:
            clock.start()
            acted, ctrl, jet, thrust = self._act_control(learner, state, z, noise)
            ctrl = clock.lap("policy", np.asarray(ctrl))
            kinematics = clock.lap("physics", physics.step(ctrl))
            stepped, info, pose, row = self._advance_record(
                learner, state, kinematics, jet, thrust, acted
            )
            done = clock.lap("task", np.asarray(info.done))
            state = clock.lap("resets", physics.restart(stepped, pose, done))
            rows.append((row, state.data.qpos, state.data.qvel, state.thrust))
        return state, self._stack(rows, state.obs)

    def _act_control_fn(
        self, learner: Learner, state: EnvState, z: jax.Array, noise: jax.Array
    ) -> tuple[dict, jax.Array, Any, jax.Array]:
        acted = self._act(learner, state.obs, z, noise)
        return acted, *jax.vmap(self.env.control)(state, acted["actions"])

    def _advance_record_fn(
        self,
        learner: Learner,
        state: EnvState,
        kinematics: Any,
        jet: Any,
        thrust: jax.Array,
        acted: dict,
    ) -> tuple[EnvState, StepInfo, Any, dict]:
        stepped, info, pose = jax.vmap(self.env.advance)(state, kinematics, jet, thrust)
        return stepped, info, pose, self._record(learner, state, acted, info, stepped)

    def _stack_fn(self, rows: list, last_obs: jax.Array) -> Rollout:
        """The per-step rows as a time-major Rollout (qpos, qvel, thrust after any reset)."""
        records = [r | {"qpos": q, "qvel": v, "thrust": t} for r, q, v, t in rows]
        stacked = jax.tree.map(lambda *x: jnp.stack(x), *records)
        return Rollout(**stacked, last_obs=last_obs)

    # -- update ---------------------------------------------------------------------------------
    def _split_rows(self, tree: Any) -> Any:
        """Rows of a minibatch split over the devices (where they split evenly), so that each
        device computes the loss of its rows and the gradient is their mean."""
        if self.config.ppo.minibatch_size % self.devices:
            return tree
        return jax.lax.with_sharding_constraint(tree, batch_sharding(self.mesh))

    def _ppo_epochs(
        self, learner: Learner, data: dict[str, jax.Array], key: jax.Array
    ) -> tuple[Any, Any, jax.Array, dict[str, jax.Array]]:
        ppo = self.config.ppo
        size = data["obs"].shape[0]

        def minibatch(carry: tuple, index: jax.Array) -> tuple[tuple, dict[str, jax.Array]]:
            policy, opt, lr = carry
            mb = self._split_rows(jax.tree.map(lambda x: x[index], data))

            def loss_fn(params: Any) -> tuple[jax.Array, dict[str, jax.Array]]:
                mean, log_std, value = self.net.apply(params, learner.obs_norm(mb["obs"]))
                loss, parts = ppo_loss(
                    mean,
                    log_std,
                    value,
                    mb,
                    ppo.clip,
                    ppo.value_coef,
                    ppo.entropy_coef,
                    ppo.value_clip,
                    ppo.bounds_coef,
                )
                kl = gaussian_kl(mb["means"], mb["log_stds"], mean, log_std).mean()
                if ppo.mirror_coef > 0:
                    obs = learner.obs_norm(self.mirror.obs(mb["obs"]))
                    of_mirrored, _, _ = self.net.apply(params, obs)
                    parts["mirror_loss"] = mirror_loss(
                        of_mirrored, self.mirror.actions(mean), log_std
                    )
                    loss = loss + ppo.mirror_coef * parts["mirror_loss"]
                return loss, {**parts, "kl": kl}

            grads, parts = jax.grad(loss_fn, has_aux=True)(policy)
            if ppo.lr_schedule == "adaptive":
                lr = adapt_learning_rate(lr, jax.lax.stop_gradient(parts["kl"]), ppo.kl_target)
            updates, opt = self.policy_tx.update(grads, opt, policy)
            policy = jax.tree.map(lambda p, u: p - lr * u, policy, updates)
            return (policy, opt, lr), parts

        def epoch(carry: tuple, k: jax.Array) -> tuple[tuple, dict[str, jax.Array]]:
            order = jax.random.permutation(k, size).reshape(ppo.minibatches, ppo.minibatch_size)
            return jax.lax.scan(minibatch, carry, order)

        start = (learner.policy, learner.policy_opt, learner.learning_rate)
        (policy, opt, lr), parts = jax.lax.scan(epoch, start, jax.random.split(key, ppo.epochs))
        return policy, opt, lr, jax.tree.map(jnp.ravel, parts)

    def _update(
        self,
        learner: Learner,
        buffer: ReplayBuffer,
        batch: Rollout,
        prior: PriorData | None,
        key: jax.Array,
    ) -> tuple[Learner, ReplayBuffer, dict[str, jax.Array]]:
        config, ppo = self.config, self.config.ppo
        k_style, k_epochs, k_disc = jax.random.split(key, 3)
        amp_norm = learner.amp_norm
        metrics: dict[str, jax.Array] = {}
        if self.use_style:
            amp_norm, style, rollout_accuracy = self.style.reward(
                learner.disc, amp_norm, prior, batch.chi, batch.info.chi_next, k_style
            )
            metrics["disc_policy_accuracy_rollout"] = rollout_accuracy
        else:
            style = jnp.zeros_like(batch.info.task_reward)
        w_style = config.reward.w_style if self.use_style else 0.0
        reward = total_reward(batch.info.task_reward, style, config.reward.w_task, w_style)
        reward = reward + ppo.gamma * batch.final_values * batch.info.truncated
        _, _, last_value = self.net.apply(learner.policy, learner.obs_norm(batch.last_obs))
        advantages, returns = gae(
            reward, batch.values, batch.info.done, last_value, ppo.gamma, ppo.lam
        )

        flat = lambda x: x.reshape(-1, *x.shape[2:])  # noqa: E731
        data = {
            "obs": flat(batch.obs),
            "actions": flat(batch.actions),
            "means": flat(batch.means),
            "log_stds": flat(batch.log_stds),
            "log_probs": flat(batch.log_probs),
            "values": flat(batch.values),
            "advantages": flat(advantages),
            "returns": flat(returns),
        }
        policy, opt, lr, parts = self._ppo_epochs(learner, data, k_epochs)
        disc, disc_opt = learner.disc, learner.disc_opt
        if self.use_style:
            pairs = flat(batch.chi), flat(batch.info.chi_next)
            if config.amp.mirror:
                pairs = tuple(jnp.concatenate([x, self.mirror.chi(x)]) for x in pairs)
            disc, disc_opt, buffer, disc_parts = self.style.train(
                disc, disc_opt, amp_norm, pairs, buffer, prior, k_disc
            )
            parts |= disc_parts
            # the discriminator before this iteration's steps (at iteration 1: the initial one)
            metrics |= {f"{k}_start": v[0] for k, v in disc_parts.items()}
        learner = Learner(
            policy=policy,
            policy_opt=opt,
            learning_rate=lr,
            disc=disc,
            disc_opt=disc_opt,
            obs_norm=learner.obs_norm.update(batch.obs),
            amp_norm=amp_norm,
            iteration=learner.iteration + 1,
            env_steps=learner.env_steps + batch.info.done.size,
        )
        metrics |= {name: value.mean() for name, value in parts.items()}
        metrics |= rollout_figures(
            batch.info, batch.thrust, self.env.t_max, self.env.config.control_hz, self.env.kinds
        )
        metrics |= {"style_reward": style.mean(), "reward": reward.mean(), "learning_rate": lr}
        return learner, buffer, metrics

    def iteration(self, learner: Learner, carry: Carry) -> tuple[Learner, Carry, dict[str, float]]:
        key, k_rollout, k_update = jax.random.split(carry.key, 3)
        share = air_share(learner.iteration, self.env.config)
        env_state = carry.env.replace(air_share=jnp.full_like(carry.env.air_share, share))
        env_state, batch = self.rollout(learner, env_state, k_rollout, jnp.array(1.0))
        learner, buffer, metrics = self.update(learner, carry.buffer, batch, self.prior, k_update)
        return learner, Carry(env_state, buffer, key), metrics | {"air_share": share}
