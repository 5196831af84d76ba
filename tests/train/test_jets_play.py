"""`motionkit play` of a policy with fitted jets: a hand-made policy package (its actor holds one
action: the standing posture and 30 % throttle on every jet; the jet model beside it, as `train
export` writes them) played from standing. The clip validates and holds per jet the commanded
throttle and the thrust, and the thrust answers the throttle step only after the engine's dead
time, then rises slowly."""

import json
from dataclasses import replace
from pathlib import Path

import jax
import numpy as np
import pytest
from flax import serialization

from motionkit.cli import main
from motionkit.dataset import read
from motionkit.dataset.validate import validate_clip
from motionkit.train import policy as package

slow = pytest.mark.slow  # compiles the play loop (about a minute on 2 cores)

FLOOR, THROTTLE = 15.0, 30.0  # %: four jets below the robot's weight, which stays standing
HIDDEN = 8
FAR = "5,5,0.6"  # a waypoint never reached in the seconds played


def policy_package(folder: Path, robot, tiny_config) -> Path:
    """A policy package whose actor's mean is one action whatever it observes."""
    from test_jets_free_run import fitted_model

    from motionkit.jet_ident.export import save_model
    from motionkit.train.env import Env

    model = fitted_model()
    env_config = replace(
        tiny_config.env, jet="lstm", jet_model=package.JET_MODEL, throttle_min=FLOOR
    )
    config = replace(
        tiny_config, env=env_config, ppo=replace(tiny_config.ppo, actor_hidden=(HIDDEN,))
    )
    env = Env(robot, replace(env_config, impl="mujoco"), jet_model=model)
    action = np.asarray(env.rest_action, np.float32).copy()
    action[env.num_joints :] = 2 * (THROTTLE - FLOOR) / (100 - FLOOR) - 1  # -0.647
    actor = {
        "Dense_0": {"kernel": np.zeros((env.obs_size, HIDDEN), np.float32),
                    "bias": np.zeros(HIDDEN, np.float32)},
        "Dense_1": {"kernel": np.zeros((HIDDEN, env.action_size), np.float32), "bias": action},
    }  # fmt: skip
    norm = {"mean": np.zeros(env.obs_size), "var": np.ones(env.obs_size), "count": np.ones(())}
    folder.mkdir()
    state = {"actor": actor, "obs_norm": jax.tree.map(np.float32, norm)}
    (folder / package.PARAMS).write_bytes(serialization.msgpack_serialize(state))
    layout = {"robot": robot.name, "joints": list(robot.joint_names),
              "jets": [jet.name for jet in robot.spec.jets]}  # fmt: skip
    (folder / package.LAYOUT).write_text(json.dumps(layout))
    (folder / package.CONFIG).write_text(config.to_toml())
    save_model(folder / package.JET_MODEL, model)
    return folder


@slow
def test_the_clip_holds_throttle_and_thrust_and_the_thrust_lags(
    robot, tiny_config, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    folder = policy_package(tmp_path / "policy", robot, tiny_config)
    policy = package.load_policy(folder)
    assert policy.config.env.throttle_min == FLOOR and policy.config.env.jet == "lstm"
    out = tmp_path / "plays"
    argv = ["play", "--policy", str(folder), "--out", str(out), "--waypoints", FAR]
    assert main([*argv, "--seconds", "1.5"]) == 0
    assert "ended at the time limit" in capsys.readouterr().out  # it stood for 1.5 s
    clip = out / "play.mcap"
    checks = validate_clip(clip, robot)
    assert all(c.ok or c.warning for c in checks), [c for c in checks if not c.ok]
    motion = read(clip)
    assert motion.frames == 90  # 1.5 s at 60 Hz
    assert motion.throttle.shape == motion.thrust.shape == (90, 4)
    # the commanded throttle: 15 + 85 (a + 1) / 2 = 30 % from the first step on
    np.testing.assert_allclose(motion.throttle, THROTTLE, atol=1e-4)
    thrust = motion.thrust.mean(1)
    jets = policy_env_jets(policy, robot)
    idle = jets.idle
    # the throttle steps from the floor to 30 % in the first frame; the model sees it 30 ms
    # late (4 of its steps of 1/120 s at 60 Hz): the first two frames (2 steps each) idle
    assert jets.steps == 2 and jets.params.delay == 4
    np.testing.assert_allclose(thrust[:2], idle, atol=0.05)
    assert thrust[4] > idle + 0.2  # then it answers
    # and rises slowly (the P250: 0.4-1.2 s to 63 % mid-range): 63 % of its rise to the last
    # frame's takes more than 0.4 s
    rise = np.flatnonzero(thrust - idle >= 0.63 * (thrust[-1] - idle))[0]
    assert thrust[-1] > idle + 15.0 and (rise + 1) / 60.0 > 0.4


def policy_env_jets(policy, robot):
    from motionkit.train.policy import policy_env

    return policy_env(policy, robot).jets
