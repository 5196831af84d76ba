"""Trained policies: the small package `motionkit train export` writes, and a policy read from
it, from a training run's folder (OUT of `motionkit train`) or from those shipped with
motionkit (`motionkit/policies/<name>/`).

POLICY_DIR/policy.msgpack   the actor's parameters (float32, or float16 with `half`) and the
                            observation normaliser (no critic, discriminator or optimiser state)
POLICY_DIR/policy.json      the robot layout it acts for (joints, jets, observation and action
                            sizes) and the run it came from
POLICY_DIR/config.toml      the resolved training config (environment, reward, action mapping)
POLICY_DIR/summary.json     the run's last training and evaluation figures
POLICY_DIR/jet_model.npz    the fitted jet model, when the config's jets are not ideal
"""

from __future__ import annotations

import json
from collections.abc import Callable
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np
from flax import serialization

from motionkit.core.errors import TrainError
from motionkit.files.outputs import check_out, claim_out, write_files
from motionkit.robot import Robot
from motionkit.train.checkpoint import NAME as CHECKPOINT
from motionkit.train.config import TrainConfig
from motionkit.train.env import Env
from motionkit.train.normalize import RunningNorm
from motionkit.train.ppo import Actor, actor_params

SHIPPED = Path(__file__).resolve().parent.parent / "policies"  # motionkit/policies/<name>/
PARAMS, LAYOUT, CONFIG, SUMMARY, JET_MODEL = (
    "policy.msgpack", "policy.json", "config.toml", "summary.json", "jet_model.npz"
)  # fmt: skip
MAX_BYTES = 2_000_000  # an exported policy ships with the package: 2 MB at most


@dataclass(frozen=True)
class Policy:
    """A policy that acts: the actor, its observation normaliser and the config it was
    trained with; `layout` is the robot it was exported for ({} for a run folder)."""

    source: Path
    config: TrainConfig
    actor: dict[str, Any]  # {"params": ...} of ppo.Actor
    obs_norm: RunningNorm
    layout: dict[str, Any]
    summary: dict[str, Any]

    @property
    def hidden(self) -> tuple[int, ...]:
        return tuple(self.config.ppo.actor_hidden)

    @property
    def obs_size(self) -> int:
        return int(self.actor["params"]["Dense_0"]["kernel"].shape[0])

    @property
    def action_size(self) -> int:
        return int(self.actor["params"][f"Dense_{len(self.hidden)}"]["kernel"].shape[1])

    def act_fn(self) -> Callable[[Any], jax.Array]:
        """obs (obs_size,) -> the action mean (action_size,), jitted: the deterministic
        policy, as evaluations run it."""
        actor, norm = Actor(self.action_size, self.hidden), self.obs_norm
        params = jax.tree.map(lambda a: jnp.asarray(a, jnp.float32), self.actor)
        return jax.jit(lambda obs: actor.apply(params, norm(jnp.asarray(obs, jnp.float32))))


# -- reading ------------------------------------------------------------------------------------
def shipped_policies() -> list[Path]:
    """The policies shipped in the package (folders with a policy.msgpack), by name."""
    if not SHIPPED.is_dir():
        return []
    return sorted(p for p in SHIPPED.iterdir() if (p / PARAMS).is_file())


DEFAULT = "walk_fly"  # the shipped policy `play` runs without --policy, when several ship


def default_policy() -> Path:
    """The shipped policy (DEFAULT where several ship); a TrainError when none ships, or
    several without DEFAULT."""
    found = shipped_policies()
    if len(found) == 1:
        return found[0]
    if SHIPPED / DEFAULT in found:
        return SHIPPED / DEFAULT
    if not found:
        raise TrainError(
            "no trained policy ships with this motionkit yet: pass --policy RUN_DIR (a "
            "`motionkit train` output) or POLICY_DIR (of `motionkit train export`)"
        )
    names = ", ".join(p.name for p in found)
    raise TrainError(f"several policies ship ({names}): choose one with --policy NAME")


def load_policy(path: Path | str | None = None) -> Policy:
    """The policy in `path`: an exported policy, a training run or a shipped policy.

    Args:
        path: an exported policy folder (or its policy.msgpack), a training run's folder, or
            the name of a shipped policy; None: the one policy that ships.

    Returns:
        The policy: its actor, observation normaliser, training config, the robot layout it
        was exported for ({} for a run folder) and the run's summary.

    Raises:
        TrainError: no such file or folder, a folder that holds no policy, none or several
            shipped policies (for None), or files that cannot be read or whose actor does not
            match its config.
    """
    if path is None:
        path = default_policy()
    path = Path(path)
    if not path.exists() and (SHIPPED / path.name / PARAMS).is_file() and path.name == str(path):
        path = SHIPPED / path.name
    if path.is_file() and path.name == PARAMS:
        path = path.parent
    if not path.exists():
        raise TrainError(f"--policy {path}: no such file or folder")
    if (path / PARAMS).is_file():
        return _load_export(path)
    if (path / CONFIG).is_file() and (path / CHECKPOINT).is_file():
        return _load_run(path)
    raise TrainError(
        f"{path}: not a policy (neither {PARAMS} of `motionkit train export` nor {CONFIG} + "
        f"{CHECKPOINT} of a training run)"
    )


def _load_run(folder: Path, checkpoint: Path | None = None) -> Policy:
    """The policy of a run folder at its latest checkpoint, or at `checkpoint` (one of its
    earlier ones: the summary then holds that iteration's rows of train.csv and eval.csv)."""
    config = TrainConfig.from_toml(folder / CONFIG)
    path = folder / CHECKPOINT if checkpoint is None else Path(checkpoint)
    state = _msgpack(path)
    try:
        actor = actor_params(state["policy"], config.ppo.actor_hidden)
        norm = _norm(state["obs_norm"])
        iteration, env_steps = int(state["iteration"]), float(state["env_steps"])
    except (KeyError, TypeError) as exc:
        raise TrainError(f"{path}: not a checkpoint of this config") from exc
    summary = _json(folder / SUMMARY) if (folder / SUMMARY).is_file() else {}
    if checkpoint is not None:
        summary |= {
            "iterations": iteration,
            "env_steps": env_steps,
            "checkpoint": str(path),
            "train": _csv_row(folder / "train.csv", iteration),
            "eval": _csv_row(folder / "eval.csv", iteration),
        }
    return _checked(Policy(folder, config, actor, norm, {}, summary))


def _csv_row(path: Path, iteration: int) -> dict[str, float]:
    """The row of metrics CSV `path` at `iteration` ({} when it has none)."""
    from motionkit.train.curves import read_table

    table = read_table(path)
    rows = np.flatnonzero(table.get("iteration", np.empty(0)) == iteration)
    if not len(rows):
        return {}
    row = {name: float(column[rows[0]]) for name, column in table.items() if name != "iteration"}
    return {name: value for name, value in row.items() if not np.isnan(value)}


def _load_export(folder: Path) -> Policy:
    state = _msgpack(folder / PARAMS)
    config = TrainConfig.from_toml(folder / CONFIG)
    if config.env.jet != "ideal" and not Path(config.env.jet_model).is_absolute():
        config = replace(
            config, env=replace(config.env, jet_model=str(folder / config.env.jet_model))
        )
    try:
        actor, norm = {"params": state["actor"]}, _norm(state["obs_norm"])
    except (KeyError, TypeError) as exc:
        raise TrainError(f"{folder / PARAMS}: not an exported policy (actor, obs_norm)") from exc
    layout = _json(folder / LAYOUT)
    summary = _json(folder / SUMMARY) if (folder / SUMMARY).is_file() else {}
    return _checked(Policy(folder, config, actor, norm, layout, summary))


def _checked(policy: Policy) -> Policy:
    """The policy, its actor's layers checked against its config's actor_hidden."""
    layers = policy.actor["params"]
    widths = [np.shape(layers.get(f"Dense_{k}", {}).get("kernel")) for k in range(len(layers))]
    hidden = policy.hidden
    if len(widths) != len(hidden) + 1 or any(len(w) != 2 for w in widths):
        raise TrainError(f"{policy.source}: its actor does not have the layers of its config")
    if tuple(w[1] for w in widths[:-1]) != hidden or policy.obs_norm.mean.shape != (
        policy.obs_size,
    ):
        raise TrainError(f"{policy.source}: its actor's sizes differ from its config's")
    return policy


def _msgpack(path: Path) -> dict[str, Any]:
    try:
        state = serialization.msgpack_restore(path.read_bytes())
    except OSError as exc:
        raise TrainError(f"{path}: cannot read it ({exc.strerror})") from exc
    except Exception as exc:  # msgpack raises its own error types
        raise TrainError(f"{path}: not a msgpack file of motionkit ({exc})") from exc
    if not isinstance(state, dict):
        raise TrainError(f"{path}: not a msgpack file of motionkit")
    return state


def _json(path: Path) -> dict[str, Any]:
    try:
        value = json.loads(path.read_text())
    except (OSError, ValueError) as exc:
        raise TrainError(f"{path}: cannot read it as JSON ({exc})") from exc
    if not isinstance(value, dict):
        raise TrainError(f"{path}: expected a JSON object")
    return value


def _norm(state: dict[str, Any]) -> RunningNorm:
    return RunningNorm(*(jnp.asarray(state[k], jnp.float32) for k in ("mean", "var", "count")))


# -- the environment a policy acts in -----------------------------------------------------------
def cpu_env(config: TrainConfig, robot: Robot, **changes: Any) -> Env:
    """The environment of `config` (its [env] keys `changes` changed) for `robot` on the
    MuJoCo backend, for this machine's CPU (a GPU run's impl and devices set aside)."""
    from motionkit.train.runner import make_env

    env = replace(config.env, **changes, impl="mujoco")
    config = replace(config, env=env, run=replace(config.run, devices=1))
    return make_env(config, robot)


def policy_env(policy: Policy, robot: Robot, **changes: Any) -> Env:
    """`cpu_env` of the policy's config (its [env] keys `changes` changed); a TrainError when
    the policy was made for another robot layout."""
    layout = policy.layout
    if layout:
        joints, jets = list(robot.joint_names), [jet.name for jet in robot.spec.jets]
        if layout.get("joints") != joints or layout.get("jets") != jets:
            raise TrainError(
                f"{policy.source}: a policy for {layout.get('robot')} "
                f"({len(layout.get('joints', []))} joints, {len(layout.get('jets', []))} jets), "
                f"not for {robot.name} ({len(joints)} joints, {len(jets)} jets)"
            )
    env = cpu_env(policy.config, robot, **changes)
    if (policy.obs_size, policy.action_size) != (env.obs_size, env.action_size):
        raise TrainError(
            f"{policy.source}: the policy observes {policy.obs_size} values and makes "
            f"{policy.action_size} actions; {robot.name}'s environment has {env.obs_size} and "
            f"{env.action_size} (a policy of another robot layout)"
        )
    return env


# -- export -------------------------------------------------------------------------------------
def export_policy(
    run: Path, out: Path, robot: Robot, *, half: bool = False, checkpoint: Path | None = None
) -> dict[str, int]:
    """Write the policy of training run `run` into `out` (see the module doc).

    Nothing is written on an error.

    Args:
        run: the training run's folder (config.toml and checkpoint).
        out: the policy package's folder.
        robot: the robot the policy acts for; its layout is written with it.
        half: store the actor's weights as float16 (half the bytes; actions within about
            1e-3 of the run's).
        checkpoint: one of the run's earlier checkpoints (OUT/evaluated/iter_N.msgpack, say)
            instead of its latest; the summary holds that iteration's figures.

    Returns:
        The bytes of each file written, by file name.

    Raises:
        TrainError: `run` is not a training run, its policy does not fit `robot`, its jet
            model cannot be read, the package would exceed MAX_BYTES, or `out` holds files
            motionkit did not write.
    """
    run, out = Path(run), Path(out)
    if not ((run / CONFIG).is_file() and (run / CHECKPOINT).is_file()):
        raise TrainError(f"{run}: not a training run (no {CONFIG} and {CHECKPOINT})")
    if checkpoint is not None and not Path(checkpoint).is_file():
        raise TrainError(f"{checkpoint}: no such checkpoint")
    policy = _load_run(run, checkpoint)
    env = policy_env(policy, robot)
    config = policy.config
    files: dict[str, bytes] = {}
    if config.env.jet != "ideal":
        model = Path(config.env.jet_model)
        try:
            files[JET_MODEL] = model.read_bytes()
        except OSError as exc:
            raise TrainError(f"[env] jet_model {model}: cannot read it ({exc.strerror})") from exc
        config = replace(config, env=replace(config.env, jet_model=JET_MODEL))
    norm = policy.obs_norm
    dtype = np.float16 if half else np.float32
    state = {
        "actor": jax.tree.map(lambda a: np.asarray(a, dtype), policy.actor["params"]),
        "obs_norm": {"mean": norm.mean, "var": norm.var, "count": norm.count},
    }
    files[PARAMS] = serialization.msgpack_serialize(jax.tree.map(np.asarray, state))
    layout = {
        "robot": robot.name,
        "model_hash": robot.model_hash,
        "joints": list(robot.joint_names),
        "jets": [jet.name for jet in robot.spec.jets],
        "observation_size": env.obs_size,
        "action_size": env.action_size,
        "actor_hidden": list(policy.hidden),
        "actor_dtype": np.dtype(dtype).name,
        "run": str(run),
        "iteration": policy.summary.get("iterations"),
    }
    files[LAYOUT] = (json.dumps(layout, indent=2) + "\n").encode()
    files[CONFIG] = config.to_toml().encode()
    files[SUMMARY] = (json.dumps(policy.summary, indent=2) + "\n").encode()
    total = sum(len(data) for data in files.values())
    if total > MAX_BYTES:
        raise TrainError(
            f"{run}: its policy package would hold {total / 1e6:.2f} MB, more than the "
            f"{MAX_BYTES / 1e6:.0f} MB a shipped policy may have"
            + ("" if half else "; --half stores the actor's weights as float16")
        )
    check_out(out, files, TrainError)
    claim_out(out, files, TrainError)
    write_files(out, files)
    return {name: len(data) for name, data in files.items()}
