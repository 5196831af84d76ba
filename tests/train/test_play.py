"""`motionkit play` and `motionkit train export`: a tiny trained policy exported and rolled out
with plain MuJoCo; the clip, the waypoint bookkeeping, export against run folder, parity of the
loop with the MJX environment's `step`, and the refusals."""

import json
import re
from dataclasses import replace
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from flax import serialization

from motionkit.cli import main
from motionkit.core.errors import TrainError
from motionkit.dataset import read
from motionkit.dataset.validate import validate_clip
from motionkit.files.outputs import MANIFEST, written_names
from motionkit.train import policy as policy_module
from motionkit.train.play import Player, parse_waypoints, report, roll_out, write_clip
from motionkit.train.policy import MAX_BYTES, load_policy

slow = pytest.mark.slow  # trains two iterations, compiles MJX (about 2 minutes on 2 cores)
FAR = "5,5,0.6"  # never reached in the seconds played


@pytest.fixture(scope="module")
def run_folder(tiny_config, robot, tmp_path_factory: pytest.TempPathFactory) -> Path:
    from motionkit.train.runner import train

    out = tmp_path_factory.mktemp("run")
    run = replace(
        tiny_config.run, iterations=2, tensorboard=False, eval_every=1, keep_evaluated=True
    )
    train(replace(tiny_config, run=run), out, robot, progress=lambda _: None)
    return out


@pytest.fixture(scope="module")
def exported(run_folder: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("export") / "policy"
    assert main(["train", "export", str(run_folder), "--out", str(out)]) == 0
    return out


def play_cli(policy: Path, out: Path, *extra: str) -> int:
    return main(["play", "--policy", str(policy), "--out", str(out), *extra])


# -- export -------------------------------------------------------------------------------------
@slow
def test_export_is_small_and_holds_the_actor_only(exported: Path, run_folder: Path) -> None:
    names = {p.name for p in exported.iterdir()}
    assert names == {"policy.msgpack", "policy.json", "config.toml", "summary.json", MANIFEST}
    assert sum(p.stat().st_size for p in exported.iterdir()) < MAX_BYTES
    state = serialization.msgpack_restore((exported / "policy.msgpack").read_bytes())
    assert set(state) == {"actor", "obs_norm"}
    # tiny recipe: actor [64, 64] -> Dense_0..2; the critic (Dense_3..5), log_std, the
    # discriminator and the optimisers stay behind
    assert set(state["actor"]) == {"Dense_0", "Dense_1", "Dense_2"}
    assert state["actor"]["Dense_2"]["kernel"].shape == (64, 27)
    layout = json.loads((exported / "policy.json").read_text())
    assert layout["action_size"] == 27 and len(layout["joints"]) == 23
    summary = json.loads((exported / "summary.json").read_text())
    assert summary["iterations"] == 2 and "eval_waypoints_per_episode" in summary["eval"]
    policy = load_policy(exported)
    from_run = load_policy(run_folder)
    for a, b in zip(jax.tree.leaves(policy.actor), jax.tree.leaves(from_run.actor), strict=True):
        np.testing.assert_array_equal(a, b)

    # --half: float16 weights, half the bytes, actions within 1e-3 (measured 6e-4)
    half = exported.parent / "half"
    assert main(["train", "export", str(run_folder), "--out", str(half), "--half"]) == 0
    small, full = (p / "policy.msgpack" for p in (half, exported))
    assert small.stat().st_size < 0.6 * full.stat().st_size
    obs = np.random.default_rng(0).standard_normal((64, policy.obs_size)).astype(np.float32)
    act, act_half = policy.act_fn(), load_policy(half).act_fn()
    assert np.abs(np.asarray(act(obs)) - np.asarray(act_half(obs))).max() < 1e-3


@slow
def test_an_evaluated_checkpoint_is_kept_and_exports(run_folder: Path, tmp_path: Path) -> None:
    import csv

    kept = run_folder / "evaluated"
    assert sorted(p.name for p in kept.iterdir()) == ["iter_1.msgpack", "iter_2.msgpack"]
    first = serialization.msgpack_restore((kept / "iter_1.msgpack").read_bytes())
    assert int(first["iteration"]) == 1 and "policy_opt" not in first  # slim
    out = tmp_path / "first"
    assert main(["train", "export", str(run_folder), "--out", str(out),
                 "--checkpoint", str(kept / "iter_1.msgpack")]) == 0  # fmt: skip
    summary = json.loads((out / "summary.json").read_text())
    rows = list(csv.DictReader((run_folder / "eval.csv").open()))
    assert [r["iteration"] for r in rows] == ["1", "2"] and summary["iterations"] == 1
    assert summary["eval"]["eval_task_reward"] == pytest.approx(float(rows[0]["eval_task_reward"]))
    assert summary["checkpoint"].endswith("iter_1.msgpack")
    latest, earlier = load_policy(run_folder), load_policy(out)
    assert not np.array_equal(
        latest.actor["params"]["Dense_0"]["kernel"], earlier.actor["params"]["Dense_0"]["kernel"]
    )  # one update apart
    missing = tmp_path / "none"
    assert main(["train", "export", str(run_folder), "--out", str(missing),
                 "--checkpoint", str(kept / "iter_9.msgpack")]) == 2  # fmt: skip
    assert not missing.exists()


# -- play ---------------------------------------------------------------------------------------
@slow
def test_play_writes_a_clip_that_validates(
    exported: Path, run_folder: Path, robot, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "plays"
    assert play_cli(exported, out, "--waypoints", f"1,0,0.6 {FAR}", "--seconds", "2") == 0
    text = capsys.readouterr().out
    assert "waypoint 1 (1.00, 0.00, 0.60) m: " in text and "waypoint 2 (5.00, 5.00" in text
    assert "real time (compilation" in text and "not counted)" in text
    clip = out / "play.mcap"
    assert written_names(out) == {"play.mcap"}
    checks = validate_clip(clip, robot)
    assert all(c.ok or c.warning for c in checks), [c for c in checks if not c.ok]
    motion = read(clip)
    if "ended at the time limit" in text:  # the tiny policy may fall before 2 s
        assert motion.frames == 120
    assert motion.rate == pytest.approx(60.0)
    np.testing.assert_allclose(motion.time[:3], [1 / 60, 2 / 60, 3 / 60], rtol=1e-6)
    route = motion.metadata.config["waypoints"]
    assert route[0] == [0.0, 1.0, 0.0, 0.6]  # [time, x, y, z] as the evaluation rollouts

    # the run folder and its export play the same clip
    again = tmp_path / "from_run"
    assert play_cli(run_folder, again, "--waypoints", f"1,0,0.6 {FAR}", "--seconds", "2") == 0
    other = read(again / "play.mcap")
    np.testing.assert_array_equal(other.base_position, motion.base_position)
    np.testing.assert_array_equal(other.joint_positions, motion.joint_positions)


@slow
def test_a_waypoint_at_the_start_is_reached_after_the_first_step(exported: Path, robot) -> None:
    from motionkit.train.policy import policy_env

    policy = load_policy(exported)
    player = Player(policy_env(policy, robot))
    start = player.data.qpos[:3].copy()
    played = roll_out(player, policy.act_fn(), [start, np.array([5.0, 5.0, 0.6])], 0.25)
    first, second = played.legs
    assert first.reached == pytest.approx(1 / 60) and first.steps == 1
    assert second.start == pytest.approx(1 / 60) and second.reached is None
    assert played.frames == 15 and played.end == "at the time limit"
    np.testing.assert_array_equal(played.target[0], start)  # pursued during step 1
    np.testing.assert_array_equal(played.target[1], [5.0, 5.0, 0.6])
    assert re.fullmatch(
        r"waypoint 1 \(0\.00, 0\.00, 0\.6\d\) m: reached at 0\.02 s \(after 0\.02 s\), "
        r"walking \(airborne 0 % of the way, on one foot \d+ %, \d+\.\d contact switches per "
        r"foot per second\), thrust \d+\.\d % of T_max",
        report(played)[0],
    )
    # the last waypoint reached ends the run; one step is too short for a clip
    player.reset(*player.standing())
    played = roll_out(player, policy.act_fn(), [start], 1.0)
    assert played.frames == 1 and played.end == "after the last waypoint, at 0.02 s"
    with pytest.raises(TrainError, match="lasted 1 step"):
        write_clip(Path("unused.mcap"), played, robot, {})


@slow
def test_another_robot_layout_is_refused(exported: Path, tmp_path: Path, capsys) -> None:
    layout = json.loads((exported / "policy.json").read_text())
    other = tmp_path / "other"
    other.mkdir()
    for path in exported.iterdir():
        (other / path.name).write_bytes(path.read_bytes())
    layout["robot"], layout["joints"] = "other", layout["joints"][:-1]
    (other / "policy.json").write_text(json.dumps(layout))
    out = tmp_path / "plays"
    assert play_cli(other, out, "--waypoints", "1,0,0.6") == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "a policy for other (22 joints, 4 jets), not for" in err
    assert not out.exists()


def play_shipped(waypoints: str, out: Path, capsys) -> tuple[list[str], list[str]]:
    """Plays the default policy along two waypoints; its printed lines and the two legs' lines,
    both reached."""
    assert main(["play", "--waypoints", waypoints, "--out", str(out)]) == 0
    lines = capsys.readouterr().out.splitlines()
    legs = [line for line in lines if line.startswith("waypoint ")]
    assert len(legs) == 2 and all(": reached at " in line for line in legs)
    return lines, legs


def test_the_shipped_policy_walks_to_both_waypoints(robot, tmp_path: Path, capsys) -> None:
    """The README's first play: the default policy walks (alternating single support, at
    least the walking goals: on one foot >= 25 %, >= 1 switch per foot per second) to both
    waypoints without a fall, and its clip validates."""
    out = tmp_path / "plays"
    lines, legs = play_shipped("1.5,0,0.6 3,1,0.6", out, capsys)
    for line in legs:
        single, switches = re.search(r"on one foot (\d+) %, (\d+\.\d) contact", line).groups()
        assert "walking (airborne" in line and int(single) >= 25 and float(switches) >= 1.0
    assert any(line.endswith("falls: 0") for line in lines)
    assert re.search(r"\d+\.\dx real time", lines[-2] + lines[-1])
    checks = validate_clip(out / "play.mcap", robot)
    assert all(c.ok or c.warning for c in checks), [c for c in checks if not c.ok]


def test_the_shipped_policy_walks_then_flies(tmp_path: Path, capsys) -> None:
    """One policy, both modes: it walks to a ground waypoint (airborne under half the way) and
    flies to the air waypoint after it, without a fall."""
    lines, legs = play_shipped("1.5,0,0.6 3,1,1.2", tmp_path / "plays", capsys)
    assert "walking (airborne" in legs[0] and "flying (airborne" in legs[1]
    assert any(line.endswith("falls: 0") for line in lines)


def test_the_gait_counters_of_a_way() -> None:
    from motionkit.train.play import Leg

    leg = Leg(np.zeros(3), steps=30, single=12, switches=4.5, airborne=3)
    assert leg.single_share == pytest.approx(0.4) and leg.airborne_share == pytest.approx(0.1)
    assert leg.switches_per_second(30.0) == pytest.approx(4.5)  # 4.5 per foot in 1 s
    assert Leg(np.zeros(3)).switches_per_second(30.0) == 0.0


# -- parity with the MJX environment ------------------------------------------------------------
def _parity(env, batch_fns, lift: float, noise: float, steps: int = 10) -> dict[str, float]:
    """Largest differences over `steps` control steps between Env.step (MJX; the session's
    jitted batch step, on a batch of one) and Player (plain MuJoCo), from the same standing
    state raised by `lift` [m], under the same actions (the rest action plus `noise` x
    N(0, 1))."""
    from motionkit.train.env.mjx import mjx

    reset, batch_step = batch_fns
    state = jax.tree.map(lambda x: x[0], reset(jax.random.split(jax.random.key(3), 1)))
    data = mjx.kinematics(env.mx, state.data.replace(qpos=state.data.qpos.at[2].add(lift)))
    state = state.replace(data=data, obs=env.observe(data, state.thrust, state.target))
    player = Player(env)
    player.reset(*(np.asarray(x, float) for x in (data.qpos, data.qvel, state.thrust)))

    def step(state, action):
        one = lambda tree: jax.tree.map(lambda x: x[0], tree)  # noqa: E731
        return map(one, batch_step(jax.tree.map(lambda x: x[None], state), action[None]))

    rng = np.random.default_rng(0)
    worst = dict.fromkeys(("base", "joints", "obs"), 0.0)
    obs, _, _ = player.observe(np.asarray(state.target))
    worst["obs"] = float(np.abs(obs - state.obs).max())
    for _ in range(steps):
        action = np.asarray(env.rest_action) + noise * rng.standard_normal(env.action_size)
        state, info = step(state, jnp.asarray(action, jnp.float32))
        assert not info.done
        player.step(action.astype(np.float32))
        obs, _, _ = player.observe(np.asarray(state.target))
        qpos = player.data.qpos
        for name, ours, theirs in (
            ("base", qpos[:3], state.data.qpos[:3]),
            ("joints", qpos[7:], state.data.qpos[7:]),
            ("obs", obs, state.obs),
        ):
            worst[name] = max(worst[name], float(np.abs(ours - np.asarray(theirs)).max()))
    return worst


@slow
def test_parity_with_the_environment_in_the_air(env, batch_fns) -> None:
    """Off the ground and below the actuators' force limits MuJoCo and MJX agree to float32
    rounding (measured: base 5e-8 m, joints 1e-7 rad, observation 2e-6 over 10 steps): the
    tolerances (100x) catch any difference in the observation, the PD mapping or the jets."""
    worst = _parity(env, batch_fns, lift=0.3, noise=0.005)
    assert worst["base"] < 1e-5 and worst["joints"] < 1e-5 and worst["obs"] < 3e-4, worst


@slow
def test_parity_with_the_environment_on_the_ground(env, batch_fns) -> None:
    """Standing, MuJoCo's contacts differ from MJX's (box-on-plane contact points; measured
    over 10 steps from a stance 1 mm deep: base 4e-4 m, joints 5e-3 rad, observation 0.28, a
    joint velocity): bounds about 4x the measured gap, so that a growing gap shows."""
    worst = _parity(env, batch_fns, lift=-0.001, noise=0.0)
    assert worst["base"] < 2e-3 and worst["joints"] < 2e-2 and worst["obs"] < 1.0, worst


# -- refusals (no training) ---------------------------------------------------------------------
def test_parse_waypoints() -> None:
    points = parse_waypoints(" 1,0,0.6   -1.5,2,1e0 ")
    np.testing.assert_array_equal(points, [[1, 0, 0.6], [-1.5, 2, 1]])
    for bad in ("1,0", "1,0,0.6,2", "1,x,0.6", "1,nan,0.6", "1,0,inf"):
        with pytest.raises(TrainError, match=f"'{bad}' is not a waypoint"):
            parse_waypoints(f"0,0,0.6 {bad}")
    with pytest.raises(TrainError, match="--waypoints is empty"):
        parse_waypoints("  ")


def test_bad_inputs_are_one_line_errors(tmp_path: Path, capsys, monkeypatch) -> None:
    out = tmp_path / "plays"
    assert main(["play", "--waypoints", "1,0,0.6 1;0;2", "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err == (
        "motionkit: error: --waypoints: '1;0;2' is not a waypoint; expected x,y,z (three "
        "finite numbers in metres, no spaces), waypoints separated by spaces\n"
    )
    empty = tmp_path / "empty"
    empty.mkdir()
    assert play_cli(empty, out, "--waypoints", "1,0,0.6") == 2
    assert "not a policy (neither policy.msgpack" in capsys.readouterr().err
    (empty / "policy.msgpack").write_bytes(b"not msgpack")
    assert play_cli(empty, out, "--waypoints", "1,0,0.6") == 2
    assert "policy.msgpack: not a msgpack file of motionkit" in capsys.readouterr().err
    assert play_cli(tmp_path / "missing", out) == 2
    assert "no such file or folder" in capsys.readouterr().err
    # no policy ships yet: the default says so and points to --policy
    monkeypatch.setattr(policy_module, "SHIPPED", tmp_path / "none")
    assert main(["play", "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert "no trained policy ships with this motionkit yet: pass --policy RUN_DIR" in err
    assert err.count("\n") == 1
    assert main(["play", "--out", str(out), "--seconds", "0"]) == 2
    assert "--seconds 0.0: expected a duration > 0" in capsys.readouterr().err
    assert main(["play", "--out", str(out), "--name", "../x"]) == 2
    assert "would be written outside" in capsys.readouterr().err
    assert not out.exists()
    with pytest.raises(SystemExit):
        main(["play", "--help"])
    assert "checkpoint.msgpack" in capsys.readouterr().out


def test_export_refuses_a_folder_that_is_no_run(tmp_path: Path, capsys) -> None:
    assert main(["train", "export", str(tmp_path), "--out", str(tmp_path / "p")]) == 2
    assert "not a training run (no config.toml and checkpoint.msgpack)" in capsys.readouterr().err
    assert not (tmp_path / "p").exists()


# -- evaluate -----------------------------------------------------------------------------------
@slow
def test_evaluate_repeats_the_runs_evaluation_and_tries_noise(run_folder: Path, capsys) -> None:
    import csv

    last = list(csv.DictReader((run_folder / "eval.csv").open()))[-1]

    def figures(*extra: str) -> dict[str, float]:
        assert main(["train", "evaluate", str(run_folder), *extra]) == 0
        lines = capsys.readouterr().out.splitlines()
        return {name: float(value) for name, value in (line.split() for line in lines)}

    again = figures()
    for name in ("task_reward", "approach_speed", "single_support_share", "episode_seconds"):
        assert again[name] == pytest.approx(float(last[f"eval_{name}"]), rel=1e-5, abs=1e-7)
    kept = run_folder.parent / "kept.msgpack"  # a checkpoint kept aside: the same figures
    kept.write_bytes((run_folder / "checkpoint.msgpack").read_bytes())
    assert figures("--checkpoint", str(kept)) == pytest.approx(again, nan_ok=True)
    assert main(["train", "evaluate", str(run_folder), "--checkpoint", str(kept) + "x"]) == 2
    assert "kept.msgpackx: no such checkpoint" in capsys.readouterr().err
    other = figures("--seed", "7")  # other starts and waypoints
    assert other["task_reward"] != pytest.approx(again["task_reward"], rel=1e-4)
    noisy = figures("--noise", "1")
    assert noisy["task_reward"] != pytest.approx(again["task_reward"], rel=1e-4)
    assert main(["train", "evaluate", str(run_folder), "--prior-starts", "0.5"]) == 2
    assert "need priors, and the run has none" in capsys.readouterr().err
    assert main(["train", "evaluate", str(run_folder), "--prior", "flight"]) == 2
    assert "no prior 'flight' in its config (its priors: none)" in capsys.readouterr().err
    # every waypoint in the air, then none: the other kind's share has no steps to count
    assert np.isnan(figures("--air-share", "1")["airborne_share_to_ground"])
    assert np.isnan(figures("--air-share", "0")["airborne_share_to_air"])


def test_the_default_policy_is_the_only_one_or_walk_fly(tmp_path: Path, monkeypatch) -> None:
    from motionkit.train import policy as policy_module

    def ship(*names: str) -> Path:
        folder = tmp_path / "-".join(names)
        for name in names:
            (folder / name).mkdir(parents=True)
            (folder / name / policy_module.PARAMS).write_bytes(b"")
        monkeypatch.setattr(policy_module, "SHIPPED", folder)
        return folder

    folder = ship("walk_fly_jets")
    assert policy_module.default_policy() == folder / "walk_fly_jets"
    folder = ship("walk_fly", "walk_fly_jets")
    assert policy_module.default_policy() == folder / "walk_fly"
    ship("a", "b")
    with pytest.raises(TrainError, match=r"several policies ship \(a, b\)"):
        policy_module.default_policy()
