"""The slim AMP + PPO trainer (MuJoCo MJX on a GPU, MuJoCo C on a CPU), for any robot with a
spec.

    from motionkit.robot import load_robot
    from motionkit.train import TrainConfig, train_policy

    robot = load_robot("robot.urdf", "robot.toml")       # no arguments: iRonCub
    config = TrainConfig.from_toml("train/tiny_cpu.toml").select_priors([])
    summary = train_policy(config, out, robot)           # OUT/summary.json, rollouts/, ...
    result = run_ablation(config, out, robot, seeds=[0, 1])  # the four prior arms x seeds
    export_policy(out, "policy", robot)                  # the small policy package
    draw_curves(out)                                     # OUT/curves.png
    played, route = play_policy(load_policy("policy"), robot, Path("play.mcap"))

`train_policy` is `motionkit.train.runner.train` (a run in a folder, resumable; the config's
PriorConfig tables name its priors); `make_env` builds the environment of a config and
`Trainer` its learner; `play_policy` rolls a policy (`load_policy`: a run folder, a package of
`export_policy` or a shipped policy) out with MuJoCo C into a clip; `enable_compile_cache`
keeps XLA's programs in the user cache. Configs import without the [train] extra (JAX, flax,
optax, MuJoCo); the rest imports it on first use, and a missing one is a TrainError naming the
extra (`require_train_extra` checks it up front).
"""

from __future__ import annotations

import importlib
from typing import Any

from motionkit.train.config import PriorConfig, TrainConfig
from motionkit.train.runtime import enable_compile_cache, require_train_extra

# exported name -> (module, attribute); `train` itself is a module of this package
_LAZY = {
    "train_policy": ("runner", "train"),
    "make_env": ("runner", "make_env"),
    "run_ablation": ("ablation", "run_ablation"),
    "Trainer": ("learner", "Trainer"),
    "export_policy": ("policy", "export_policy"),
    "load_policy": ("policy", "load_policy"),
    "play_policy": ("play", "play"),
    "draw_curves": ("curves", "draw_curves"),
}

__all__ = [
    "PriorConfig",
    "TrainConfig",
    "enable_compile_cache",
    "require_train_extra",
    *_LAZY,
]


def __getattr__(name: str) -> Any:
    if name in _LAZY:
        require_train_extra(f"motionkit.train.{name}")
        module, attribute = _LAZY[name]
        return getattr(importlib.import_module(f"motionkit.train.{module}"), attribute)
    raise AttributeError(f"module 'motionkit.train' has no attribute {name!r}")
