"""The evaluation's transition figures on hand-made records (take-off: from the jets' first rise
on the way to an air waypoint to lift-off; landing: from the descent's start to touch-down),
the thrust per metre on flat ground, and an evaluation of fitted jets that reports them and
keeps the commanded throttle."""

from dataclasses import replace
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from motionkit.train.env import StepInfo
from motionkit.train.figures import rollout_figures, transition_figures

T, N, HZ = 50, 3, 10.0  # 50 steps of 3 robots at 10 Hz: a flight is 10 steps airborne
AIR_LEVEL = 0.75  # m: the base height between ground (0.6) and air (0.9) waypoints


def blank() -> dict[str, np.ndarray]:
    """Records of robots standing (base 0.6 m up) toward ground waypoints, jets at rest."""
    names = ("done", "airborne", "air_target", "hit", "timed_out")
    arrays = {name: np.zeros((T, N), bool) for name in names}
    arrays["base_lift"] = np.full((T, N), 0.6)
    return arrays


def fly(arrays: dict, robot: int, start: int, end: int, lift: list[float]) -> None:
    """Robot `robot` airborne in steps [start, end), its base at `lift` there."""
    arrays["airborne"][start:end, robot] = True
    arrays["base_lift"][start:end, robot] = lift


def records() -> tuple[dict[str, np.ndarray], np.ndarray]:
    arrays, command = blank(), np.zeros((T, N))
    # robot 0: reaches a ground waypoint in step 4; the air one is pursued from step 5 to its
    # hit in step 20, a ground one after. The jets rise in steps 1-2 (toward the ground
    # waypoint: not this way's), then from step 7; lift-off in step 12: 12 - 7 + 1 = 6 steps.
    # Airborne 12-29, the base at 1.0 m, 0.9 m in step 25, below 0.75 m from 26; touch-down
    # in step 30: 30 - 25 = 5 steps.
    arrays["hit"][[4, 20], 0] = True
    arrays["air_target"][5:21, 0] = True
    command[1:3, 0], command[7:30, 0] = 0.3, 0.6
    fly(arrays, 0, 12, 30, [1.0] * 13 + [0.9, 0.74, 0.7, 0.65, 0.62])
    # robot 1: an episode toward an air waypoint to its fall in step 19 (airborne from step
    # 3, the jets up from step 0, an episode's first: 3 - 0 + 1 = 4 steps; no touch-down);
    # the next starts airborne (a prior frame) toward a ground waypoint, 1.1 m up to step 30,
    # 0.7 m after; touch-down in step 33: 33 - 30 = 3 steps.
    arrays["done"][19, 1] = True
    arrays["air_target"][:20, 1] = True
    command[:20, 1] = 0.5
    fly(arrays, 1, 3, 20, 1.0)
    fly(arrays, 1, 20, 33, [1.1] * 11 + [0.7] * 2)
    # robot 2: the jets rise in step 2 on the way to a ground waypoint (reached in step 9)
    # and stay up: the lift-off toward the air one (step 15) has no rise on its way; a hop
    # (steps 5-7) is no flight; the flight lasts past the records (no touch-down).
    arrays["hit"][9, 2] = True
    arrays["air_target"][10:, 2] = True
    command[2:, 2] = 0.5
    fly(arrays, 2, 5, 8, 0.7)
    fly(arrays, 2, 15, T, 1.2)
    return arrays, command


def test_takeoff_and_landing_by_hand() -> None:
    arrays, command = records()
    figures = transition_figures(arrays, command, AIR_LEVEL, HZ)
    assert figures["takeoff_seconds"] == pytest.approx((0.6 + 0.4) / 2)  # robots 0 and 1
    assert figures["landing_seconds"] == pytest.approx((0.5 + 0.3) / 2)


def test_an_episode_counts_the_mean_of_its_transitions() -> None:
    """Robot 0 takes off again after landing (jets down in step 31, up in step 33, lift-off
    in step 36): its episode's take-off is the mean of 6 and 4 steps, 0.5 s."""
    arrays, command = records()
    arrays["hit"][31, 0], arrays["air_target"][32:, 0] = True, True
    command[30:33, 0], command[33:, 0] = 0.0, 0.7
    fly(arrays, 0, 36, T, 1.0)
    figures = transition_figures(arrays, command, AIR_LEVEL, HZ)
    assert figures["takeoff_seconds"] == pytest.approx((0.5 + 0.4) / 2)


def test_without_transitions_the_figures_are_nan() -> None:
    """Robots that only walk, and a long flight that stays below the air level (a low hop)."""
    arrays = blank()
    fly(arrays, 0, 5, 20, 0.7)  # 1.5 s airborne toward a ground waypoint, never 0.75 m up
    figures = transition_figures(arrays, np.zeros((T, N)), AIR_LEVEL, HZ)
    assert np.isnan(figures["takeoff_seconds"]) and np.isnan(figures["landing_seconds"])


def test_thrust_per_metre_on_flat_ground() -> None:
    """Flat ground has it too: robot 1's two jets push 60 N for 2 steps of 0.5 s (120 N s)
    while the two robots move 0.5 m a step (4 m): 30 N s per metre."""
    fields = {name: np.zeros((4, 2), bool) for name in StepInfo.__dataclass_fields__}
    fields |= {"feet_down": np.ones((4, 2, 2), bool), "moved": np.full((4, 2), 0.5)}
    info = StepInfo(**{k: jnp.asarray(v) for k, v in fields.items() if k != "terms"}, terms={})
    thrust = np.zeros((4, 2, 2))
    thrust[:2, 1] = 60.0
    figures = rollout_figures(info, jnp.asarray(thrust), jnp.full(2, 100.0), 2.0)
    assert float(figures["thrust_per_metre"]) == pytest.approx(30.0)


@pytest.mark.slow  # compiles the tiny trainer's rollout (about a minute on 2 cores)
def test_an_evaluation_of_fitted_jets(robot, tiny_config, tmp_path: Path) -> None:
    """`evaluate` reports the transitions and the thrust per metre, keeps each step's jet
    command and environment 0's throttle (the action's, above the 15 % floor), and its clip
    holds that throttle."""
    from test_jets_free_run import fitted_model

    from motionkit.jet_ident.export import save_model
    from motionkit.train.evaluate import evaluate, first_episode
    from motionkit.train.runner import build_trainer

    save_model(tmp_path / "model.npz", fitted_model())
    env = replace(
        tiny_config.env, jet="lstm", jet_model=str(tmp_path / "model.npz"), throttle_min=15.0
    )
    config, trainer, _ = build_trainer(replace(tiny_config, env=env), robot)
    learner, _ = trainer.init(0)
    metrics, arrays = evaluate(trainer, learner, jax.random.key(1), 2, noise=1.0)
    assert {"eval_takeoff_seconds", "eval_landing_seconds"} <= set(metrics)
    assert np.isfinite(metrics["eval_thrust_per_metre"]) and metrics["eval_thrust_per_metre"] > 0
    steps = 2 * config.ppo.rollout_steps
    assert arrays["command"].shape == (steps, config.ppo.num_envs)
    throttle = arrays["throttle"]
    assert throttle.shape == (steps, 1, 4) and throttle.min() >= 15.0 and throttle.max() <= 100.0
    # the mean command of environment 0 is its throttle's share above the floor
    np.testing.assert_allclose(
        (throttle[:, 0] - 15.0).mean(-1) / 85.0, arrays["command"][:, 0], atol=1e-5
    )
    clip = first_episode(arrays, robot, config.env.control_hz, {"clip": "evaluation"})
    assert clip is not None
    np.testing.assert_allclose(clip.throttle, throttle[: clip.frames, 0])
