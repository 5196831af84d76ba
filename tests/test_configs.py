"""Every stage's config: its constructors refuse bad values with the stage's error (naming the
field, what it should be and what it got), the defaults and every shipped recipe load, and the
loader locates TOML mistakes (file, [table], key)."""

from __future__ import annotations

import math
from dataclasses import asdict, replace
from importlib import resources
from pathlib import Path
from typing import Any

import pytest

from motionkit import recipes
from motionkit.core.errors import (
    DatasetError,
    JetIdentError,
    MotionkitError,
    PipelineError,
    RetargetError,
    RobotModelError,
    TrainError,
    TrajoptError,
)
from motionkit.core.tomlfile import load
from motionkit.dataset.physics import PhysicsConfig
from motionkit.jet_ident.config import BenchConfig, JetIdentConfig, ModelConfig
from motionkit.jet_ident.config import TrainConfig as JetTrainConfig
from motionkit.pipeline.config import (
    JetIdentStage,
    PipelineConfig,
    RetargetStage,
    TrainStage,
    TrajoptStage,
)
from motionkit.retarget.config import Balance, RetargetConfig, RobotPoints
from motionkit.retarget.config import Weights as RetargetWeights
from motionkit.robot.spec import LimitDefaults, RobotSpec, SimulationSpec
from motionkit.train.config import (
    AmpConfig,
    EnvConfig,
    PpoConfig,
    PriorConfig,
    RewardConfig,
    RunConfig,
    TrainConfig,
)
from motionkit.trajopt.config import Contacts, Jets, Replay, Scenario, Solver, TrajoptConfig
from motionkit.trajopt.config import Weights as TrajoptWeights
from motionkit.trajopt.library import LibrarySolve, read_library

# The shipped recipes: one folder per stage at the repository root, and how each one loads.
REPO = recipes.ROOT  # the built-in recipes, one folder per stage
STAGES: dict[str, tuple[Path, Any, type[MotionkitError]]] = {
    "retarget": (REPO / "retarget", RetargetConfig.from_toml, RetargetError),
    "trajopt": (REPO / "trajopt", TrajoptConfig.from_toml, TrajoptError),
    "train": (REPO / "train", TrainConfig.from_toml, TrainError),
    "jet_ident": (REPO / "jet_ident", JetIdentConfig.from_toml, JetIdentError),
    "pipeline": (REPO / "pipeline", PipelineConfig.from_toml, PipelineError),
}
LIBRARY = REPO / "trajopt" / "library.toml"  # a flight library, not a recipe: read_library
SPEC_TEXT = resources.files("motionkit.robot").joinpath("ironcub.toml").read_text()
RECIPES = sorted(path for folder, _, _ in STAGES.values() for path in folder.glob("*.toml"))

SPEC = RobotSpec.builtin()
NAN, INF = math.nan, math.inf
POSITIVE = (0.0, -1.0, NAN, INF)  # refused by a "> 0" rule
NON_NEGATIVE = (-1.0, NAN, INF)  # refused by a ">= 0" rule
AT_LEAST_ONE = (0, -1)
SHARE = (-0.1, 1.5, NAN)  # outside [0, 1]
FINITE = (NAN, INF, -INF)

# (a valid config, a field, values it refuses, the stage's error)
REFUSED = [
    (RetargetConfig(), "iterations", AT_LEAST_ONE, RetargetError),
    (RetargetConfig(), "settle_iterations", AT_LEAST_ONE, RetargetError),
    (RetargetConfig(), "smoothing_hz", NON_NEGATIVE, RetargetError),
    (RetargetConfig(), "contact_speed", POSITIVE, RetargetError),
    (RetargetConfig(), "contact_hysteresis", (0.9, NAN), RetargetError),
    (RetargetConfig(), "collision_margin", NON_NEGATIVE, RetargetError),
    (RetargetConfig(), "arm_abduction", FINITE, RetargetError),
    (RetargetConfig(), "kind", ("amble",), RetargetError),
    (RetargetWeights(), "contact_foot_position", NON_NEGATIVE, RetargetError),
    (RobotPoints(), "knee", ((),), RetargetError),
    (Balance(), "passes", (-1,), RetargetError),
    (Balance(), "max_shift", POSITIVE, RetargetError),
    (TrajoptConfig(), "rate", POSITIVE, TrajoptError),
    (Scenario(), "knots", (7, 0, -1), TrajoptError),
    (Scenario(), "target", ((0.0, 0.0, NAN), (INF, 0.0, 1.0)), TrajoptError),
    (Scenario(), "thrust_fraction", (0.0, 1.5, NAN), TrajoptError),
    (Scenario(), "step_land", (0.0, 1.0, NAN), TrajoptError),
    (Scenario(), "apex_clearance", NON_NEGATIVE, TrajoptError),
    (Scenario(), "kind", ("hop",), TrajoptError),
    (TrajoptWeights(), "thrust_rate", NON_NEGATIVE, TrajoptError),
    (Contacts(), "mu", POSITIVE, TrajoptError),
    (Contacts(), "eps", ((), (1e-2, 0.0), (NAN,)), TrajoptError),
    (Jets(), "max_rate", POSITIVE, TrajoptError),
    (Solver(), "dt", NON_NEGATIVE, TrajoptError),
    (Solver(), "dt_min", (*POSITIVE, 0.2), TrajoptError),  # 0.2: above dt_max
    (Solver(), "tol", POSITIVE, TrajoptError),
    (Solver(), "max_iter", AT_LEAST_ONE, TrajoptError),
    (Solver(), "mu_strategy", ("probing",), TrajoptError),
    (Replay(), "orientation_kd", NON_NEGATIVE, TrajoptError),
    (Replay(), "yaw_weight", POSITIVE, TrajoptError),
    (EnvConfig(), "control_hz", POSITIVE, TrainError),
    (EnvConfig(), "substeps", AT_LEAST_ONE, TrainError),
    (EnvConfig(), "reset_from_prior", SHARE, TrainError),
    (EnvConfig(), "air_height", ((1.5, 0.9), (NAN, 1.0), (-1.0, 1.0)), TrainError),
    (EnvConfig(), "joint_noise", NON_NEGATIVE, TrainError),
    (RewardConfig(), "v_desired", POSITIVE, TrainError),
    (RewardConfig(), "w_thrust", NON_NEGATIVE, TrainError),
    (PpoConfig(), "num_envs", AT_LEAST_ONE, TrainError),
    (PpoConfig(), "learning_rate", POSITIVE, TrainError),
    (PpoConfig(), "gamma", (0.0, 1.5, NAN), TrainError),
    (PpoConfig(), "max_grad_norm", POSITIVE, TrainError),
    (PpoConfig(), "actor_hidden", ((64, 0),), TrainError),
    (AmpConfig(), "learning_rate", POSITIVE, TrainError),
    (AmpConfig(), "batch_size", (0, -2, 7), TrainError),
    (AmpConfig(), "replay_keep", (0.0, 1.5, NAN), TrainError),
    (RunConfig(), "iterations", AT_LEAST_ONE, TrainError),
    (RunConfig(), "max_minutes", NON_NEGATIVE, TrainError),
    (PriorConfig(("walk",)), "weight", POSITIVE, TrainError),
    (PriorConfig(("walk",)), "paths", ((),), TrainError),
    (BenchConfig(), "rate_hz", POSITIVE, JetIdentError),
    (BenchConfig(), "substeps", AT_LEAST_ONE, JetIdentError),
    (BenchConfig(), "noise_std_n", NON_NEGATIVE, JetIdentError),
    (BenchConfig(), "reference_c", FINITE, JetIdentError),
    (BenchConfig(), "train_seeds", ((), (1, -1)), JetIdentError),
    (ModelConfig(), "hidden", AT_LEAST_ONE, JetIdentError),
    (JetTrainConfig(), "learning_rate", POSITIVE, JetIdentError),
    (JetTrainConfig(), "clip_norm", POSITIVE, JetIdentError),
    (JetTrainConfig(), "validation_fraction", (0.0, 1.0, NAN), JetIdentError),
    (RetargetStage(), "jobs", (-1,), PipelineError),
    (TrajoptStage(), "jobs", (-1,), PipelineError),
    (TrainStage(), "jet", ("rate",), PipelineError),
    (PhysicsConfig(), "friction", POSITIVE, DatasetError),
    (PhysicsConfig(), "smoothing_hz", NON_NEGATIVE, DatasetError),
    (PhysicsConfig(), "min_explained_share", SHARE, DatasetError),
    (SPEC, "forward", ((0.0, 0.0, 0.0), (0.0, 0.0, -1.0), (2.0, 0.0, 0.0), (NAN, 0, 0)), None),
    (SPEC, "joints", ((), ("a", "a")), None),
    (SPEC.jets[0], "t_max", POSITIVE, None),
    (SPEC.limits, "default_effort", POSITIVE, None),
    (SPEC.simulation, "timestep", POSITIVE, None),
    (SPEC.simulation, "damping", NON_NEGATIVE, None),
    (SPEC.simulation.pd[0], "kp", POSITIVE, None),
]

# (a valid config, a field, a value at the edge of its rule that it keeps)
KEPT = [
    (RetargetConfig(), "smoothing_hz", 0.0),  # 0: off
    (RetargetConfig(), "contact_hysteresis", 1.0),
    (Balance(), "passes", 0),
    (Scenario(), "knots", 8),
    (Scenario(), "thrust_fraction", 1.0),
    (Scenario(), "step_length", -0.2),  # a step backwards
    (Solver(), "dt", 0.0),  # 0: optimised
    (Replay(), "position_kp", 0.0),  # 0: off
    (EnvConfig(), "air_probability", 1.0),
    (PpoConfig(), "gamma", 1.0),
    (AmpConfig(), "updates", 0),
    (RunConfig(), "eval_every", 0),
    (BenchConfig(), "ambient_drift_c", -1.0),  # the bench cools
    (RetargetStage(), "jobs", 0),  # 0: one per CPU
    (PhysicsConfig(), "cop_margin", 0.0),
    (SPEC, "forward", (0.0, 1.0, 0.0)),
    (SPEC.simulation.pd[0], "kd", 0.0),
]

# Classes that construct from their defaults alone.
DEFAULTS = [
    RetargetConfig, RetargetWeights, RobotPoints, Balance,
    TrajoptConfig, Scenario, TrajoptWeights, Contacts, Jets, Solver, Replay,
    TrainConfig, EnvConfig, RewardConfig, PpoConfig, AmpConfig, RunConfig,
    JetIdentConfig, BenchConfig, ModelConfig, JetTrainConfig,
    RetargetStage, TrajoptStage, JetIdentStage, TrainStage,
    PhysicsConfig, LimitDefaults, SimulationSpec,
]  # fmt: skip

# (stage, recipe file, text replaced in it, its replacement, what the error says after the file)
MISTAKES = [
    ("retarget", "cmu_walk.toml", "clips = [",
     "weights = { foot_positon = 1.0 }\nclips = [",
     "[weights]: unknown keys ['foot_positon']; known: ['contact_foot_orientation',"),
    ("retarget", "cmu_walk.toml", "clips = [",
     "weights = { foot_position = 'heavy' }\nclips = [",
     "[weights]: 'foot_position' should be float, got 'heavy'"),
    ("retarget", "cmu_walk.toml", "clips = [", "smoothing_hz = -1\nclips = [",
     "'smoothing_hz' should be finite and >= 0, got -1.0"),
    ("trajopt", "takeoff.toml", "knots = 20", "knot = 20", "[scenario]: unknown keys ['knot']"),
    ("trajopt", "takeoff.toml", "knots = 20", "knots = 20.5",
     "[scenario]: 'knots' should be int, got 20.5"),
    ("trajopt", "takeoff.toml", "knots = 20", "knots = 20\n[solver]\ndt_max = nan",
     "[solver]: 'dt_max' should be finite and > 0, got nan"),
    ("trajopt", "takeoff.toml", "[scenario]", "weights = 3\n[scenario]",
     "[weights]: should be a table, got 3"),
    ("train", "tiny_cpu.toml", "num_envs = 16", "num_env = 16", "[ppo]: unknown keys ['num_env']"),
    ("train", "tiny_cpu.toml", "actor_hidden = [64, 64]", "actor_hidden = 64",
     "[ppo]: 'actor_hidden' should be [int, ...], got 64"),
    ("train", "tiny_cpu.toml", "learning_rate = 1e-3\nkl_target", "learning_rate = 0\nkl_target",
     "[ppo]: 'learning_rate' should be finite and > 0, got 0.0"),
    ("train", "paper_gpu.toml", '[priors.walk]\npaths = ["datasets/walk"]',
     '[priors.walk]\npaths = "datasets/walk"',
     "[priors.walk]: 'paths' should be [str, ...], got 'datasets/walk'"),
    ("jet_ident", "p250.toml", "window = 300", "windw = 300", "[train]: unknown keys ['windw']"),
    ("jet_ident", "p250.toml", "ambient_c = [15.0, 25.0]", "ambient_c = [15.0]",
     "[bench]: 'ambient_c' should be [float, float], got [15.0]"),
    ("jet_ident", "p250.toml", "rate_hz = 100.0", "rate_hz = inf",
     "[bench]: 'rate_hz' should be finite and > 0, got inf"),
    ("pipeline", "tiny_cpu.toml", "full_recipe =", "full_recpe =",
     "[train]: unknown keys ['full_recpe']"),
    ("pipeline", "tiny_cpu.toml", "jobs = 0", "jobs = 'all'",
     "[retarget]: 'jobs' should be int, got 'all'"),
    ("pipeline", "tiny_cpu.toml", "jobs = 0", "jobs = -1",
     "[retarget]: 'jobs' should be finite and >= 0, got -1"),
]  # fmt: skip

# (text replaced in the iRonCub spec, its replacement, what the error says after the file)
SPEC_MISTAKES = [
    ("damping = 0.5", "dampng = 0.5", "[simulation]: unknown keys ['dampng']"),
    ("t_max = 250.0", "t_max = 0.0", "[jets[0]]: 't_max' should be finite and > 0, got 0.0"),
    ("timestep = 0.002", "timestep = -0.002", "[simulation]: 'timestep' should be finite and > 0"),
    ("forward = [-1.0, 0.0, 0.0]", "forward = [0, 0, 0]", "'forward' should be a horizontal unit"),
    (
        "forward = [-1.0, 0.0, 0.0]",
        "forward = [-1.0, 0.0]",
        "'forward' should be [float, float, float], got [-1.0, 0.0]",
    ),
    ('sole = "l_sole"', "sole = 1", "[feet[0]]: 'sole' should be str, got 1"),
    ("kp = 500.0", "kp = -500.0", "[simulation.pd[2]]: 'kp' should be finite and > 0, got -500.0"),
    ("torso_pitch = 0.25", "torso_pitch = nan", "'posture' should be finite angles"),
]


def _name(value: object) -> str:
    return type(value).__name__


@pytest.mark.parametrize(
    ("config", "name", "value", "error"),
    [
        pytest.param(
            config, name, value, error or RobotModelError, id=f"{_name(config)}.{name}={value}"
        )
        for config, name, values, error in REFUSED
        for value in values
    ],
)
def test_bad_values_are_refused(
    config: object, name: str, value: object, error: type[MotionkitError]
) -> None:
    with pytest.raises(error) as refused:
        replace(config, **{name: value})
    message = str(refused.value)
    assert message.startswith(f"'{name}' should be ") and message.endswith(f", got {value!r}")


@pytest.mark.parametrize(
    ("config", "name", "value"),
    [pytest.param(*case, id=f"{_name(case[0])}.{case[1]}={case[2]}") for case in KEPT],
)
def test_values_at_the_edge_of_a_rule_are_kept(config: object, name: str, value: object) -> None:
    assert getattr(replace(config, **{name: value}), name) == value


@pytest.mark.parametrize("cls", DEFAULTS, ids=lambda cls: f"{cls.__module__}.{cls.__name__}")
def test_defaults_construct_and_load_back(cls: type) -> None:
    config = cls()
    assert load(cls, asdict(config), "<test>", MotionkitError) == config
    assert load(cls, {}, "<test>", MotionkitError) == config


def test_the_robot_spec_loads_back() -> None:
    data = {key: value for key, value in asdict(SPEC).items() if key != "source"}
    assert RobotSpec.from_dict(data, SPEC.source) == SPEC
    assert SPEC.forward == (-1.0, 0.0, 0.0) and [jet.t_max for jet in SPEC.jets] == [250.0] * 4
    assert dict(SPEC.posture)["l_knee"] == -0.6 and SPEC.feet[1].side == "right"


def test_every_stage_ships_recipes() -> None:
    assert {path.parent.name for path in RECIPES} == set(STAGES)
    assert LIBRARY in RECIPES


@pytest.mark.parametrize("path", RECIPES, ids=lambda path: f"{path.parent.name}/{path.name}")
def test_shipped_recipes_load(path: Path) -> None:
    if path == LIBRARY:
        solves = read_library(path)
        assert solves and all(isinstance(solve, LibrarySolve) for solve in solves)
        return
    _, load_recipe, _ = STAGES[path.parent.name]
    config = load_recipe(path)
    if hasattr(config, "from_dict"):  # the resolved config reads back as itself
        assert type(config).from_dict(config.to_dict()) == config
    else:
        assert config.source == path


@pytest.mark.parametrize(
    ("stage", "recipe", "old", "new", "message"),
    MISTAKES,
    ids=[f"{case[0]}/{case[1]}:{case[3].split(chr(10))[0]}" for case in MISTAKES],
)
def test_recipe_mistakes_name_the_file_table_and_key(
    tmp_path: Path, stage: str, recipe: str, old: str, new: str, message: str
) -> None:
    folder, load_recipe, error = STAGES[stage]
    text = (folder / recipe).read_text()
    assert old in text
    path = tmp_path / recipe
    path.write_text(text.replace(old, new, 1))
    with pytest.raises(error) as refused:
        load_recipe(path)
    assert str(refused.value).startswith(f"{path}: {message}")


@pytest.mark.parametrize(
    ("old", "new", "message"), SPEC_MISTAKES, ids=[c[1] for c in SPEC_MISTAKES]
)
def test_robot_spec_mistakes_name_the_file_table_and_key(
    tmp_path: Path, old: str, new: str, message: str
) -> None:
    assert old in SPEC_TEXT
    path = tmp_path / "robot.toml"
    path.write_text(SPEC_TEXT.replace(old, new, 1))
    with pytest.raises(RobotModelError) as refused:
        RobotSpec.from_toml(path)
    assert str(refused.value).startswith(f"{path}: {message}")


def test_command_line_overrides_are_checked() -> None:
    with pytest.raises(TrajoptError, match=r"^<command line>: \[scenario\]: 'knots' should be at"):
        TrajoptConfig().with_scenario(knots=3)
    with pytest.raises(TrajoptError, match=r"\[scenario\]: 'target' should be \[float, float, f"):
        TrajoptConfig().with_scenario(target=(1.0, 2.0))
    assert TrajoptConfig().with_scenario(target=[1, 2, 3]).scenario.target == (1.0, 2.0, 3.0)


def test_to_toml_quotes_keys_toml_would_not_read_bare() -> None:
    import tomllib

    from motionkit.core.tomlfile import to_toml

    data = {"slowdown": 1.25, "trim": {"11_01": [0.0, 2.7], "take 3.bvh": [1.0, 2.0]}}
    text = to_toml(data)
    assert "11_01 = [0.0, 2.7]" in text and '"take 3.bvh" = [1.0, 2.0]' in text
    assert tomllib.loads(text) == data
