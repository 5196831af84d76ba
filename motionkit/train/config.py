"""The trainer's config: frozen dataclasses with their defaults here, filled from TOML recipes.

A recipe has the tables [env], [reward], [ppo], [amp], [run] and one [priors.NAME] table per
motion prior (paths of MCAP clips or folders, a weight); a key left out keeps its default.
The defaults are the paper's GPU settings; `train/tiny_cpu.toml` shrinks them for tests.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path
from typing import Any

from motionkit.core.checks import check, refusal
from motionkit.core.errors import TrainError
from motionkit.core.tomlfile import load, read_toml, to_toml

SCENARIOS = ("flat", "terrain")
JETS = ("ideal", "lstm", "grey_box", "selected")  # the last three: models of jet_model
ACTION_MAPPINGS = ("range", "stand")
LR_SCHEDULES = ("constant", "adaptive")
JET_ACTIONS = ("rate", "thrust")  # what the ideal jet's action sets
# "auto": MJX on JAX where a GPU is present, else MuJoCo; "jax": MJX on JAX (any device);
# "warp": MJX on MuJoCo Warp (NVIDIA GPUs); "mujoco": MuJoCo C on the CPU's cores
IMPLS = ("auto", "jax", "warp", "mujoco")
TERRAIN_KINDS = ("flat", "rough", "stones", "pits")  # the tiles of the "terrain" scenario
MIN_TILE = 4.0  # m: a tile holds its pad and a route 1 m from its edges


@dataclass(frozen=True)
class EnvConfig:
    """The MJX environment: control, resets, jets, waypoints, termination, terrain."""

    scenario: str = "flat"  # "flat" or "terrain" (rough ground, stepping stones, pits)
    control_hz: float = 60.0
    substeps: int = 4  # physics steps per control step (timestep 1 / (control_hz * substeps))
    episode_seconds: float = 10.0
    # joint targets: "range": mid-range + action_scale * (joint range) * a (the AMP reference);
    # "stand": standing posture + action_scale [rad] * a
    action_mapping: str = "range"
    action_scale: float = 0.7
    reset_from_prior: float = 0.85  # chance that a reset starts in a prior frame (else standing)
    # "ideal": a jet whose thrust moves at up to thrust_rate_max; "lstm", "grey_box" or
    # "selected" (the one of the two that won jet-ident's validation): action = throttle, the
    # model from jet_model
    jet: str = "ideal"
    jet_model: str = ""  # model.npz written by `motionkit jet-ident fit` (jet other than ideal)
    thrust_rate_max: float = 300.0  # N/s, ideal jet
    # the ideal jet's action: "rate": the thrust rate a * thrust_rate_max; "thrust": the thrust
    # set point (a + 1) / 2 * T_max, approached at up to thrust_rate_max (as a throttle is)
    jet_action: str = "rate"
    # the fitted models' least throttle [%], in [0, 100): action a in [-1, 1] gives the
    # throttle throttle_min + (100 - throttle_min) (a + 1) / 2, the rest action (-1) the floor
    # (the paper's LSTM variant: 15 %, about 40 N per P250 engine)
    throttle_min: float = 0.0
    initial_thrust: tuple[float, float] = (0.0, 0.0)  # N per jet at a standing reset (ideal jet)
    # the share of T_max the (ideal) jets may give: 0 holds them off, as in walking stages where
    # thrust would steady a shuffle instead of the legs learning to step
    thrust_limit: float = 1.0
    min_base_height: float = 0.4  # m above the terrain; lower ends the episode (a fall)
    waypoint_distance: tuple[float, float] = (0.7, 2.0)  # m between consecutive waypoints
    waypoint_radius: float = 0.3  # m: a waypoint closer than this is reached
    # deg: a new waypoint lies within this angle of the robot's facing (180: any direction);
    # a prior of straight walks has no turn in place to imitate for a waypoint behind
    waypoint_angle: float = 180.0
    # a waypoint not reached within factor * distance / v_desired + extra seconds is replaced
    waypoint_timeout: bool = True
    timeout_factor: float = 1.5
    timeout_extra: float = 2.0  # s
    air_probability: float = 0.5  # chance that a new waypoint is in the air (after the ramp)
    air_curriculum: int = 0  # iterations over which that chance rises from 0 (0: no ramp)
    ground_height: float = 0.6  # m: base height of a waypoint on the ground (standing)
    air_height: tuple[float, float] = (0.9, 1.5)  # m above the terrain for air waypoints
    joint_noise: float = 0.05  # rad, uniform noise on the standing posture at reset
    solver_iterations: int = 4  # MJX Newton iterations (cheap and good enough at 240 Hz)
    ls_iterations: int = 6
    # the physics: "auto" (MJX on a GPU, MuJoCo on a CPU), "jax" (MJX), "warp" (MJX on MuJoCo
    # Warp, NVIDIA GPUs, `motionkit[warp]`) or "mujoco" (MuJoCo C, `mujoco.batch`, all cores)
    impl: str = "auto"
    # The "terrain" scenario's course (`motionkit.train.env.courses`): a tile per level (rows,
    # from easy to hard) and kind (columns), each tile_size metres square with a flat pad in the
    # middle where episodes start; terrain_seed draws its bumps and stones (evaluations use
    # seeds from courses.HELD_OUT on, which training should not)
    terrain_levels: int = 10
    terrain_kinds: tuple[str, ...] = ("flat", "rough", "stones", "pits")
    tile_size: float = 8.0  # m: an episode of 7 s at 0.8 m/s stays within its tile
    terrain_seed: int = 0
    terrain_size: float = 16.0  # m, unused (the course before the tiled layout; old configs load)
    # the curriculum of levels: a robot whose episode reached route_waypoints waypoints without
    # a fall moves up a level, one that fell moves down, one past the top goes to a random
    # level; episodes start at levels 0 to max_start_level
    terrain_curriculum: bool = True
    max_start_level: int = 0
    # the waypoints of an episode's route: the curriculum's goal, and a success in the
    # evaluation per kind and level when reached in turn, none missed, without a fall
    route_waypoints: int = 3

    @property
    def control_dt(self) -> float:
        return 1.0 / self.control_hz

    @property
    def max_steps(self) -> int:
        return round(self.episode_seconds * self.control_hz)

    def __post_init__(self) -> None:
        check(self, TrainError, SCENARIOS, "scenario")
        check(self, TrainError, JETS, "jet")
        check(self, TrainError, ACTION_MAPPINGS, "action_mapping")
        check(self, TrainError, JET_ACTIONS, "jet_action")
        check(self, TrainError, IMPLS, "impl")
        if self.jet != "ideal" and not self.jet_model:
            raise TrainError(
                f"jet = '{self.jet}' needs 'jet_model', the model.npz of jet-ident fit"
            )
        check(self, TrainError, "> 0", "control_hz", "episode_seconds", "action_scale")
        check(self, TrainError, "> 0", "thrust_rate_max", "waypoint_radius", "ground_height")
        check(self, TrainError, "in (0, 180]", "waypoint_angle")
        check(self, TrainError, "> 0", "terrain_size")
        check(self, TrainError, ">= 1", "terrain_levels", "route_waypoints")
        check(self, TrainError, ">= 0", "max_start_level")
        check(self, TrainError, "non-empty", "terrain_kinds")
        check(self, TrainError, "distinct", "terrain_kinds")
        for kind in self.terrain_kinds:
            if kind not in TERRAIN_KINDS:
                expected = "kinds among " + ", ".join(map(repr, TERRAIN_KINDS))
                raise refusal(TrainError, "terrain_kinds", expected, self.terrain_kinds)
        if not self.tile_size >= MIN_TILE:
            raise refusal(TrainError, "tile_size", f"at least {MIN_TILE} m", self.tile_size)
        check(self, TrainError, ">= 1", "substeps", "solver_iterations", "ls_iterations")
        check(self, TrainError, ">= 0", "timeout_factor", "timeout_extra", "air_curriculum")
        check(self, TrainError, ">= 0", "min_base_height", "joint_noise", "terrain_seed")
        check(self, TrainError, "in [0, 1]", "air_probability", "reset_from_prior")
        check(self, TrainError, ">= 0", "waypoint_distance", "air_height", "initial_thrust")
        check(self, TrainError, "[low, high]", "waypoint_distance", "air_height", "initial_thrust")
        if self.jet != "ideal" and self.jet_action != "rate":
            raise TrainError(
                f"jet_action = '{self.jet_action}' needs jet = 'ideal' (a fitted jet's action "
                "is its throttle)"
            )
        check(self, TrainError, "in [0, 1]", "thrust_limit")
        if self.jet != "ideal" and self.thrust_limit != 1.0:
            raise TrainError(
                "'thrust_limit' needs jet = 'ideal' (a fitted jet's thrust is its own)"
            )
        if not (math.isfinite(self.throttle_min) and 0.0 <= self.throttle_min < 100.0):
            expected = "finite and in [0, 100) %"
            raise refusal(TrainError, "throttle_min", expected, self.throttle_min)
        if self.jet == "ideal" and self.throttle_min != 0.0:
            raise TrainError(
                "'throttle_min' needs a fitted jet (jet other than 'ideal'; the ideal jet has no "
                "throttle)"
            )
        if self.jet != "ideal" and self.initial_thrust != (0.0, 0.0):
            raise TrainError("'initial_thrust' needs jet = 'ideal' (the LSTM starts at idle)")
        if self.waypoint_timeout and self.timeout_factor + self.timeout_extra <= 0:
            raise TrainError("a waypoint timeout needs timeout_factor or timeout_extra > 0")


@dataclass(frozen=True)
class RewardConfig:
    """Task reward weights and scales (the paper's table) and the task/style mix."""

    w_target: float = 0.1  # w_c: exp(-c1 |x_d - p|^2)
    w_velocity: float = 0.7  # w_v: exp(-c2 (v_d - speed toward the target)^2)
    w_facing: float = 0.2  # w_f: cosine between the facing and the direction to the target
    w_thrust: float = 0.11  # w_T: -|T / T_max|^2
    c1: float = 0.5
    c2: float = 0.5
    v_desired: float = 0.5  # m/s (the walking priors average 0.40-0.61 m/s)
    w_task: float = 0.5  # w_G
    w_style: float = 0.5  # w_S (0 when no prior is used)
    # Not in the paper (0: off): each foot's swing while another foot is down, the clearance
    # up to swing_height times the horizontal sole speed up to v_desired (both as shares)
    w_swing: float = 0.0
    swing_height: float = 0.08  # m: the walking prior's soles rise 8-9 cm in a step
    # Not in the paper (0: off): -mean_j T_j / T_max on the way to a ground waypoint
    w_ground_thrust: float = 0.0

    def __post_init__(self) -> None:
        check(self, TrainError, ">= 0", "w_target", "w_velocity", "w_facing", "w_thrust")
        check(self, TrainError, ">= 0", "w_task", "w_style", "w_swing", "w_ground_thrust")
        check(self, TrainError, "> 0", "c1", "c2", "v_desired", "swing_height")


@dataclass(frozen=True)
class PpoConfig:
    """PPO; defaults are the paper's GPU settings and, where the paper is silent, the AMP
    reference's (fixed action std, bounds loss, no value clipping, constant learning rate)."""

    num_envs: int = 4096
    rollout_steps: int = 16  # steps per environment per iteration
    epochs: int = 6
    minibatch_size: int = 32768
    gamma: float = 0.99
    lam: float = 0.95
    learning_rate: float = 5e-5
    lr_schedule: str = "constant"  # or "adaptive": towards kl_target
    kl_target: float = 0.008
    clip: float = 0.2
    value_clip: float = 0.0  # clip of the value step around the old value (0: off)
    entropy_coef: float = 0.0
    value_coef: float = 5.0
    bounds_coef: float = 10.0  # penalty on action means outside [-1, 1]
    max_grad_norm: float = 1.0
    # fixed action std, near the AMP reference's exp(-2.9) = 0.055. It is PPO's trust region too:
    # an Adam step moves the mean by about the same amount at any std, so its KL grows as
    # 1 / std^2. At 0.01 (which a robot standing under that noise survives; 0.05 topples it) the
    # walking recipe learned nothing on a CPU where 0.05 learned to stand (docs/train.md)
    init_std: float = 0.05
    # the std of the jet actions (0: init_std). The jets' thrust set points are 4 of the robot's
    # outputs and need to move far from rest (0 N) to hover (44 % of T_max per jet)
    jet_std: float = 0.0
    learn_std: bool = False
    # std of the initial weights of the actor's mean layer: the mean starts at the rest action
    # plus about mean_init_scale * sqrt(last hidden width) of noise from the observation. At
    # 0.01 the untrained walk_cpu policy ([256, 256]) falls from standing in 0.7 s on both
    # backends; at 0.001 it stands (0.09 falls per 10 s episode; docs/train.md)
    mean_init_scale: float = 0.001
    actor_hidden: tuple[int, ...] = (512, 256, 128)
    critic_hidden: tuple[int, ...] = (512, 256, 128)
    # weight of the mirror loss: mean over actions of ((mu(mirror(s)) - mirror(mu(s))) / std)^2,
    # which pulls the policy toward acting as the mirror image of itself (0: off)
    mirror_coef: float = 0.0

    def action_std(self, joints: int, jets: int) -> tuple[float, ...]:
        """The std of each action: the joints' (init_std), then the jets' (jet_std or init_std)."""
        return (self.init_std,) * joints + (self.jet_std or self.init_std,) * jets

    def __post_init__(self) -> None:
        check(self, TrainError, ">= 1", "num_envs", "rollout_steps", "epochs", "minibatch_size")
        check(self, TrainError, ">= 1", "actor_hidden", "critic_hidden")
        check(self, TrainError, "> 0", "learning_rate", "kl_target", "clip", "init_std")
        check(self, TrainError, "> 0", "max_grad_norm")
        check(self, TrainError, ">= 0", "mean_init_scale", "jet_std")
        check(self, TrainError, ">= 0", "value_clip", "entropy_coef", "value_coef", "bounds_coef")
        check(self, TrainError, ">= 0", "mirror_coef")
        check(self, TrainError, "in (0, 1]", "gamma", "lam")
        check(self, TrainError, LR_SCHEDULES, "lr_schedule")
        if (self.num_envs * self.rollout_steps) % self.minibatch_size:
            raise TrainError(
                f"num_envs x rollout_steps ({self.num_envs * self.rollout_steps}) must be a "
                f"multiple of minibatch_size ({self.minibatch_size})"
            )

    @property
    def minibatches(self) -> int:
        return self.num_envs * self.rollout_steps // self.minibatch_size


@dataclass(frozen=True)
class AmpConfig:
    """The discriminator on pairs (chi_t, chi_t+1) of AMP features; defaults are the AMP
    reference settings (IsaacGymEnvs HumanoidAMP)."""

    hidden: tuple[int, ...] = (1024, 512)
    learning_rate: float = 5e-5
    updates: int = 0  # discriminator steps per iteration (0: one per PPO minibatch)
    batch_size: int = 4096  # expert and policy pairs per discriminator step
    gradient_penalty: float = 5.0  # weight of |grad_x D|^2 at the dataset samples
    logit_reg: float = 0.05  # weight of |W|^2 of the output layer
    weight_decay: float = 1e-4  # weight of |W|^2 of every layer
    buffer_size: int = 1_000_000  # policy transitions in the replay buffer
    replay_keep: float = 0.01  # once it is full, the chance that a new transition goes in
    style_scale: float = 2.0  # r_S = style_scale * -log(max(1 - D, 1e-4))
    # the robot's left-right mirror (`motionkit.robot.mirror`): each prior clip is also used
    # mirrored (its pairs and reset frames), and the discriminator sees each policy pair
    # mirrored as well
    mirror: bool = False

    def __post_init__(self) -> None:
        check(self, TrainError, ">= 1", "hidden", "batch_size", "buffer_size")
        check(self, TrainError, "> 0", "learning_rate", "style_scale")
        check(self, TrainError, ">= 0", "updates", "gradient_penalty", "logit_reg", "weight_decay")
        check(self, TrainError, "in (0, 1]", "replay_keep")
        if self.batch_size % 2:
            raise refusal(
                TrainError, "batch_size", "even (half replay, half rollout)", self.batch_size
            )


@dataclass(frozen=True)
class RunConfig:
    """The loop: iterations, seed, logging, evaluation and checkpoints."""

    iterations: int = 3000
    seed: int = 0
    log_every: int = 10  # iterations between printed progress lines
    eval_every: int = 250  # iterations between evaluations (0: only at the end)
    eval_rollouts: int = 10  # rollout chunks (of rollout_steps) per evaluation
    checkpoint_every: int = 250
    # keep a slim checkpoint of every evaluation (OUT/evaluated/iter_N.msgpack, about a third
    # of checkpoint.msgpack each): the figures swing between evaluations, and the best may
    # not be the last (`train evaluate --checkpoint`, `train export --checkpoint`)
    keep_evaluated: bool = False
    max_minutes: float = 0.0  # stop after this wall time (0: no limit)
    tensorboard: bool = True  # also write TensorBoard events (needs tensorboardX)
    # local devices the environments are split over (0 or "all": every one); parameters are
    # replicated, gradients averaged over the global batch (`motionkit.train.devices`)
    devices: int | str = 1

    def __post_init__(self) -> None:
        check(self, TrainError, ">= 1", "iterations", "log_every", "eval_rollouts")
        count = isinstance(self.devices, int) and not isinstance(self.devices, bool)
        if self.devices != "all" and not (count and self.devices >= 0):
            raise refusal(TrainError, "devices", "a count >= 1, 0 or 'all'", self.devices)
        check(self, TrainError, ">= 1", "checkpoint_every")
        check(self, TrainError, ">= 0", "seed", "eval_every", "max_minutes")


@dataclass(frozen=True)
class PriorConfig:
    """One motion prior: MCAP clips (files or folders, relative to the working directory)."""

    paths: tuple[str, ...]
    weight: float = 1.0  # share of the prior in the discriminator's dataset samples

    def __post_init__(self) -> None:
        check(self, TrainError, "non-empty", "paths")
        check(self, TrainError, "> 0", "weight")


GOAL_OPERATORS = (">=", "<=")
# keys a curriculum stage may not change: the shapes of what is learned
FIXED_KEYS = {"ppo": ("actor_hidden", "critic_hidden"), "amp": ("hidden",)}


@dataclass(frozen=True)
class StageConfig:
    """One stage of a curriculum ([curriculum.NAME], in the recipe's order): the keys of
    [env], [reward], [ppo] and [amp] it changes from the recipe's, the priors' weights, and
    when it ends: at the first evaluation that meets every goal (`hold` evaluations in a row;
    a goal on a training figure uses its mean since the previous evaluation)
    once `min_iterations` have run in the stage, or after `max_iterations` (0: no limit; the
    last stage runs to [run] iterations)."""

    env: dict[str, Any] = field(default_factory=dict)
    reward: dict[str, Any] = field(default_factory=dict)
    ppo: dict[str, Any] = field(default_factory=dict)
    amp: dict[str, Any] = field(default_factory=dict)
    priors: dict[str, float] = field(default_factory=dict)  # prior name -> weight
    # figure -> ">= x" or "<= x": an eval.csv column, or a train.csv column (its mean since
    # the previous evaluation)
    goals: dict[str, str] = field(default_factory=dict)
    hold: int = 1  # evaluations in a row that must meet the goals
    min_iterations: int = 0
    max_iterations: int = 0

    def __post_init__(self) -> None:
        check(self, TrainError, ">= 1", "hold")
        check(self, TrainError, ">= 0", "min_iterations", "max_iterations")
        for name, goal in self.goals.items():
            parse_goal(name, goal)
        for table, keys in FIXED_KEYS.items():
            fixed = sorted(set(getattr(self, table)) & set(keys))
            if fixed:
                raise TrainError(
                    f"[{table}] {fixed} cannot change between stages (the networks' shapes)"
                )
        for name, weight in self.priors.items():
            if not (isinstance(weight, float) and math.isfinite(weight) and weight > 0):
                raise refusal(TrainError, f"priors.{name}", "a weight > 0", weight)


def parse_goal(name: str, goal: str) -> tuple[str, float]:
    """A goal ">= x" or "<= x" as (operator, x); TrainError naming the figure otherwise."""
    operator, _, number = goal.strip().partition(" ")
    try:
        threshold = float(number)
    except ValueError:
        threshold = math.nan
    if operator not in GOAL_OPERATORS or not math.isfinite(threshold):
        raise refusal(TrainError, f"goals.{name}", "'>= x' or '<= x', x a finite number", goal)
    return operator, threshold


@dataclass(frozen=True)
class TrainConfig:
    env: EnvConfig = EnvConfig()
    reward: RewardConfig = RewardConfig()
    ppo: PpoConfig = PpoConfig()
    amp: AmpConfig = AmpConfig()
    run: RunConfig = RunConfig()
    priors: dict[str, PriorConfig] = field(default_factory=dict)  # [priors.NAME] tables
    # [curriculum.NAME] tables, in order (none: one stage, the recipe itself)
    curriculum: dict[str, StageConfig] = field(default_factory=dict)

    def __post_init__(self) -> None:
        devices, envs = self.run.devices, self.ppo.num_envs
        if isinstance(devices, int) and devices > 0 and envs % devices:
            raise TrainError(
                f"[ppo] num_envs ({envs}) must be a multiple of [run] devices ({devices})"
            )
        for name, stage in self.curriculum.items():
            unknown = sorted(set(stage.priors) - set(self.priors))
            if unknown:
                raise TrainError(
                    f"[curriculum.{name}.priors] names {unknown}, the config has [priors.*] "
                    f"tables for {sorted(self.priors) or 'none'}"
                )
            try:
                self.stage(name)
            except TrainError as exc:
                raise TrainError(f"[curriculum.{name}]: {exc}") from exc

    def stage(self, name: str) -> TrainConfig:
        """The config a curriculum stage trains with: the recipe with the stage's keys and
        prior weights, without a curriculum."""
        stage = self.curriculum[name]
        tables = {}
        for table in ("env", "reward", "ppo", "amp"):
            base = getattr(self, table)
            values = asdict(base) | getattr(stage, table)
            tables[table] = load(type(base), values, f"stage {name!r}", TrainError)
        priors = {
            n: replace(p, weight=stage.priors.get(n, p.weight)) for n, p in self.priors.items()
        }
        return replace(self, **tables, priors=priors, curriculum={})

    @classmethod
    def from_toml(cls, path: Path) -> TrainConfig:
        return cls.from_dict(read_toml(path, "train config", TrainError), str(path))

    @classmethod
    def from_dict(cls, data: dict[str, Any], source: str = "<config>") -> TrainConfig:
        return load(cls, data, source, TrainError)

    def select_priors(self, names: list[str]) -> TrainConfig:
        """The same config with only the named priors (`--priors`)."""
        missing = [n for n in names if n not in self.priors]
        if missing:
            raise TrainError(
                f"--priors names {missing}, the config has [priors.*] tables for "
                f"{sorted(self.priors) or 'none'}"
            )
        stages = {
            name: replace(s, priors={n: w for n, w in s.priors.items() if n in names})
            for name, s in self.curriculum.items()
        }
        return replace(self, priors={n: self.priors[n] for n in names}, curriculum=stages)

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)

    def to_toml(self) -> str:
        """The resolved config as TOML (what `from_toml` reads back)."""
        return to_toml(self.to_dict())
