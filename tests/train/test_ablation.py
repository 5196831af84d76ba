"""The prior ablation over seeds: its table's statistics against hand-computed ones, the
arms' configs (priors dropped from the curriculum stages too), the charts; the order, keeping,
resuming and time budget of its runs with training replaced by a stand-in; and, slow, the tiny
recipe's real runs: every arm x seed, an interrupted run resumed, a second call that trains
nothing, the budget of a call."""

import contextlib
import io
import json
import shutil
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from motionkit.core.errors import TrainError
from motionkit.robot import Robot
from motionkit.train.ablation import (
    ARMS,
    RADAR,
    TABLE,
    arm_config,
    arm_statistics,
    curves_chart,
    metrics_table,
    radar_chart,
    run_ablation,
    run_figures,
    run_folder,
)
from motionkit.train.config import PriorConfig, StageConfig, TrainConfig


def _run(evaluation: dict, finished: bool = True, episode_seconds: float = 10.0) -> dict:
    return {"finished": finished, "episode_seconds": episode_seconds, "eval": evaluation}


def hand_runs() -> dict:
    """Two seeds of walk, one of flight, an unfinished none (left out of the statistics)."""
    return {
        "walk+flight": {},
        "walk": {
            "0": _run(
                {
                    "eval_episode_seconds": 5.0,
                    "eval_task_reward": 0.2,
                    "eval_thrust_usage": 0.3,
                    "eval_waypoints_per_episode": 1.0,
                    "eval_airborne_share_to_air": None,  # no air waypoint: null in JSON
                    "eval_falls_per_episode": 0.0,
                }
            ),
            "1": _run(
                {
                    "eval_episode_seconds": 10.0,
                    "eval_task_reward": 0.4,
                    "eval_thrust_usage": 0.5,
                    "eval_waypoints_per_episode": 3.0,
                    "eval_airborne_share_to_air": 0.5,
                    "eval_falls_per_episode": 1.0,
                }
            ),
        },
        "flight": {"0": _run({"eval_task_reward": -0.8, "eval_episode_seconds": 1.0}, True, 2.0)},
        "none": {"0": _run({"eval_task_reward": 5.0}, finished=False)},
    }


def test_table_mean_and_spread_by_hand() -> None:
    figures = run_figures(hand_runs())
    assert set(figures["walk"]) == {"0", "1"} and figures["none"] == {}
    # episode duration over the maximum (10 s; flight's 2 s), reward over the largest |reward|
    # of the finished runs (0.8: the unfinished 5.0 is not counted), thrust as 1 - T/T_max
    assert figures["walk"]["0"][RADAR[0]] == 0.5 and figures["flight"]["0"][RADAR[0]] == 0.5
    assert figures["walk"]["1"][RADAR[1]] == pytest.approx(0.5)
    assert figures["flight"]["0"][RADAR[1]] == pytest.approx(-1.0)
    assert figures["walk"]["0"][RADAR[2]] == pytest.approx(0.7)
    statistics = arm_statistics(figures)
    waypoints = statistics["walk"]["waypoints per episode"]
    assert waypoints == {"mean": 2.0, "min": 1.0, "max": 3.0, "runs": 2, "of": 2}
    assert statistics["walk"][RADAR[2]]["mean"] == pytest.approx(0.6)
    assert statistics["walk"]["airborne share to air"]["runs"] == 1
    lines = metrics_table(statistics, seeds=2).splitlines()
    assert lines[0] == "| arm | runs | " + " | ".join(TABLE) + " |"
    assert lines[1] == "|---" * (len(TABLE) + 2) + "|"
    assert lines[2] == "| walk+flight | 0 of 2 | " + " | ".join(["n/a"] * len(TABLE)) + " |"
    walk = [
        "0.75 [0.5, 1]",  # episode duration / max: 0.5 and 1.0
        "0.375 [0.25, 0.5]",  # task reward / 0.8: 0.25 and 0.5
        "0.6 [0.5, 0.7]",  # 1 - T/T_max: 0.7 and 0.5
        "2 [1, 3]",  # waypoints per episode
        "n/a",  # airborne share to ground: in neither evaluation
        "0.5 [0.5, 0.5] (1)",  # to air: one run of the two has it
        "0.5 [0, 1]",  # falls per episode
    ]
    assert lines[3] == "| walk | 2 of 2 | " + " | ".join(walk) + " |"
    assert lines[4].startswith("| flight | 1 of 2 | 0.5 [0.5, 0.5] | -1 [-1, -1] | n/a |")
    assert lines[5] == "| none | 0 of 2 | " + " | ".join(["n/a"] * len(TABLE)) + " |"
    assert "mean [min, max]" in lines[-1] and "1 - T/T_max" in lines[-1]


def two_prior_config() -> TrainConfig:
    """Both priors and a curriculum whose first stage weighs both."""
    priors = {"walk": PriorConfig(("w",)), "flight": PriorConfig(("f",))}
    stages = {
        "first": StageConfig(priors={"walk": 2.0, "flight": 0.5}, max_iterations=5),
        "second": StageConfig(priors={"flight": 3.0}),
    }
    config = TrainConfig(priors=priors, curriculum=stages)
    return replace(config, run=replace(config.run, iterations=4, max_minutes=5.0))


def test_arm_config_drops_the_priors_from_the_stages_too() -> None:
    config = two_prior_config()
    walk = arm_config(config, "walk", seed=3)
    assert list(walk.priors) == ["walk"] and walk.run.seed == 3
    assert walk.curriculum["first"].priors == {"walk": 2.0}
    assert walk.curriculum["second"].priors == {}
    assert walk.stage("first").priors["walk"].weight == 2.0
    flight = arm_config(config, "flight", seed=0)
    assert flight.curriculum["first"].priors == {"flight": 0.5}
    none = arm_config(config, "none", seed=0)
    assert none.priors == {} and all(not s.priors for s in none.curriculum.values())
    both = arm_config(config, "walk+flight", seed=1)
    assert both.curriculum == config.curriculum and sorted(both.priors) == ["flight", "walk"]
    # the call's time left caps the config's [run] max_minutes; 0 keeps it
    assert arm_config(config, "walk", 0, minutes=2.0).run.max_minutes == 2.0
    assert arm_config(config, "walk", 0, minutes=9.0).run.max_minutes == 5.0
    assert arm_config(config, "walk", 0).run.max_minutes == 5.0
    free = replace(config, run=replace(config.run, max_minutes=0.0))
    assert arm_config(free, "walk", 0, minutes=2.0).run.max_minutes == 2.0


def test_radar_chart_png(tmp_path: Path) -> None:
    figures = run_figures(hand_runs())
    figures["none"] = {"0": dict.fromkeys(TABLE, float("nan"))}  # NaN draws as 0
    path = tmp_path / "ablation.png"
    radar_chart(path, figures)
    import matplotlib.image

    image = matplotlib.image.imread(path)
    assert image.shape[0] > 300 and image.shape[1] > 300
    assert np.unique(image.reshape(-1, image.shape[-1]), axis=0).shape[0] > 50  # not blank
    assert list(ARMS) == ["walk+flight", "walk", "flight", "none"]


def _logs(folder: Path, evaluations: list[tuple[int, float]], steps_per_iteration: int) -> None:
    """A run's train.csv (env_steps per iteration) and eval.csv (iteration, waypoints)."""
    folder.mkdir(parents=True)
    last = max(i for i, _ in evaluations)
    rows = [f"{i},{i * steps_per_iteration}" for i in range(1, last + 1)]
    (folder / "train.csv").write_text("iteration,env_steps\n" + "\n".join(rows) + "\n")
    rows = [f"{i},{v},0.25" for i, v in evaluations]
    (folder / "eval.csv").write_text(
        "iteration,eval_waypoints_per_episode,eval_thrust_usage\n" + "\n".join(rows) + "\n"
    )


def test_eval_curves_over_env_steps(tmp_path: Path) -> None:
    from motionkit.train.ablation import eval_curve

    _logs(tmp_path / "a", [(2, 1.0), (4, 3.0), (4, 5.0)], 100)  # 4 logged twice: the last
    iterations, steps, values = eval_curve(tmp_path / "a", "eval_waypoints_per_episode")
    assert iterations.tolist() == [2, 4] and steps.tolist() == [200, 400]
    assert values.tolist() == [1.0, 5.0]
    assert eval_curve(tmp_path / "a", "1 - eval_thrust_usage")[2].tolist() == [0.75, 0.75]
    assert all(len(a) == 0 for a in eval_curve(tmp_path / "none", "eval_falls_per_episode"))
    _logs(tmp_path / "b", [(2, 2.0)], 100)  # a run that reached fewer evaluations
    folders = {"walk": {0: tmp_path / "a", 1: tmp_path / "b"}, "none": {0: tmp_path / "x"}}
    curves_chart(tmp_path / "curves.png", folders)
    assert (tmp_path / "curves.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    curves_chart(tmp_path / "nothing.png", {"none": {0: tmp_path / "x"}})
    assert not (tmp_path / "nothing.png").exists()  # no evaluation yet: no chart


class StandIn:
    """`train` replaced: writes a checkpoint (its iteration) and a summary like the runner's;
    `stop_at` (folder name -> iteration) ends a run short, as [run] max_minutes would; each
    call takes `seconds` on the ablation's clock (`now`)."""

    def __init__(self) -> None:
        self.calls: list[tuple[str, bool, list[str], int, float]] = []
        self.stop_at: dict[str, int] = {}
        self.seconds = 0.0
        self.now = [0.0]

    def __call__(self, config: TrainConfig, out: Path, robot: object, **options: object) -> dict:
        from flax import serialization

        from motionkit.files.outputs import claim_out

        self.now[0] += self.seconds
        name = f"{out.parent.name}/{out.name}"
        resume = options.get("resume", False)
        assert resume == (out / "checkpoint.msgpack").exists()
        run = config.run
        self.calls.append((name, resume, sorted(config.priors), run.seed, run.max_minutes))
        done = self.stop_at.pop(name, run.iterations)
        claim_out(out, ["checkpoint.msgpack", "summary.json"], TrainError)
        state = {"iteration": np.int64(done), "policy": {}}
        (out / "checkpoint.msgpack").write_bytes(serialization.msgpack_serialize(state))
        reward = 0.1 * len(config.priors) + 0.01 * run.seed
        summary = {"iterations": done, "env_steps": 10.0 * done}
        summary["eval"] = {"eval_task_reward": reward}
        (out / "summary.json").write_text(json.dumps(summary))
        return summary | {"seconds": self.seconds}


@pytest.fixture
def stand_in(monkeypatch: pytest.MonkeyPatch) -> StandIn:
    import motionkit.train.ablation as ablation
    import motionkit.train.runner as runner

    fake = StandIn()
    monkeypatch.setattr(runner, "train", fake)
    monkeypatch.setattr(ablation, "_clock", lambda: fake.now[0])
    return fake


def test_runs_go_seed_major_and_resume_keeps_the_finished(
    tmp_path: Path, stand_in: StandIn
) -> None:
    config = two_prior_config()
    stand_in.stop_at["none/seed_1"] = 2  # stopped short (by its max_minutes)
    lines: list[str] = []
    result = run_ablation(config, tmp_path, None, [0, 1], progress=lines.append)
    order = [call[0] for call in stand_in.calls]
    assert order == [f"{a.replace('+', '_')}/seed_{s}" for s in (0, 1) for a in ARMS]
    assert stand_in.calls[3] == ("none/seed_0", False, [], 0, 5.0)
    assert stand_in.calls[4][2:4] == (["flight", "walk"], 1)
    assert result["finished"] == 7 and result["total"] == 8
    assert "none seed 1 (run 8 of 8): stopped at iteration 2 of 4" in " ".join(lines)
    assert lines[-1].startswith("ablation: 7 of 8 runs finished (") and "--resume" in lines[-1]
    saved = json.loads((tmp_path / "ablation.json").read_text())
    assert saved["runs"]["walk"]["1"]["eval"] == {"eval_task_reward": 0.11}
    assert saved["runs"]["none"]["1"]["finished"] is False
    assert (tmp_path / "ablation.md").read_text() == result["table"]
    assert "| none | 1 of 2 |" in result["table"]
    assert (tmp_path / "ablation.png").stat().st_size > 10_000
    assert not (tmp_path / "ablation_curves.png").exists()  # the stand-in logs no evaluation

    with pytest.raises(TrainError, match=r"holds ablation runs already \(walk_flight/seed_0, "):
        run_ablation(config, tmp_path, None, [0, 1])
    stand_in.calls.clear()
    lines.clear()
    result = run_ablation(config, tmp_path, None, [0, 1], resume=True, progress=lines.append)
    assert stand_in.calls == [("none/seed_1", True, [], 1, 5.0)]  # the unfinished alone
    assert sum("kept, finished at iteration 4" in line for line in lines) == 7
    assert result["finished"] == 8 and "--resume" not in lines[-1]


def test_the_time_of_a_call_bounds_its_runs(tmp_path: Path, stand_in: StandIn) -> None:
    """--max-minutes: the run in training gets what is left as its max_minutes; once it is
    spent no run starts; --resume goes on where the call stopped."""
    config = two_prior_config()
    stand_in.seconds = 90.0
    stand_in.stop_at["walk_flight/seed_0"] = 1  # its max_minutes ran out
    lines: list[str] = []
    result = run_ablation(config, tmp_path, None, [0], max_minutes=1.5, progress=lines.append)
    assert [c[0] for c in stand_in.calls] == ["walk_flight/seed_0"]
    assert stand_in.calls[0][4] == 1.5  # what was left of the call's 1.5 min (below 5)
    assert lines[0].endswith("walk_flight/seed_0 (at most 1.5 min)")
    assert "the time of this call is spent before walk seed 0 (run 2 of 4)" in lines[-2]
    assert result["finished"] == 0 and "--resume goes on" in lines[-1]
    assert "(1.5 of 1.5 min in this call)" in lines[-1]
    assert "| walk+flight | 0 of 1 |" in (tmp_path / "ablation.md").read_text()
    assert not (tmp_path / "ablation.png").exists()  # no finished run: no radar yet
    stand_in.seconds = 0.0
    result = run_ablation(config, tmp_path, None, [0], resume=True, progress=lines.append)
    assert [c[:2] for c in stand_in.calls[1:]] == [
        ("walk_flight/seed_0", True),
        ("walk/seed_0", False),
        ("flight/seed_0", False),
        ("none/seed_0", False),
    ]
    assert result["finished"] == 4


def test_refusals(tmp_path: Path) -> None:
    config = two_prior_config()
    with pytest.raises(TrainError, match=r"needs \[priors\.walk\] and \[priors\.flight\]"):
        run_ablation(config.select_priors(["walk"]), tmp_path, None)
    with pytest.raises(TrainError, match="expected distinct seeds >= 0"):
        run_ablation(config, tmp_path, None, [0, 0])
    assert not any(tmp_path.iterdir())


# -- the tiny recipe's real runs ------------------------------------------------------------------

ITERATIONS = 2


@pytest.fixture(scope="module")
def recipe(config_with_priors: TrainConfig, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The tiny recipe with both priors, 2 iterations (evaluated at each) and a curriculum whose
    first stage (which lasts) weighs both priors."""
    stages = {
        "both": StageConfig(priors={"walk": 2.0, "flight": 0.5}),
        "later": StageConfig(priors={"flight": 1.0}),
    }
    run = replace(
        config_with_priors.run,
        iterations=ITERATIONS,
        eval_every=1,
        checkpoint_every=1,
        tensorboard=False,
    )
    config = replace(config_with_priors, run=run, curriculum=stages)
    path = tmp_path_factory.mktemp("recipe") / "ablation.toml"
    path.write_text(config.to_toml())
    return path


@pytest.fixture(scope="module")
def ablation(recipe: Path, robot: Robot, tmp_path_factory: pytest.TempPathFactory) -> dict:
    """walk+flight seed 0 trained for 1 iteration (as an interrupted run leaves it), then
    `motionkit train ablation --seeds 0,1 --resume`, then the same call again."""
    from motionkit.cli import main
    from motionkit.files.outputs import claim_out
    from motionkit.train.runner import train

    out = tmp_path_factory.mktemp("ablation")
    config = TrainConfig.from_toml(recipe)
    short = arm_config(config, "walk+flight", 0)
    short = replace(short, run=replace(short.run, iterations=1))
    claim_out(out, ["walk_flight"], TrainError)  # as an ablation call claims them
    claim_out(out / "walk_flight", ["seed_0", "seed_1"], TrainError)
    train(short, run_folder(out, "walk+flight", 0), robot)
    calls = []
    args = ["train", "ablation", "--config", str(recipe), "--seeds", "0,1", "--out", str(out)]
    for _ in range(2):
        printed = io.StringIO()
        with contextlib.redirect_stdout(printed):
            code = main([*args, "--resume"])
        checkpoints = {p: p.stat().st_mtime_ns for p in out.glob("*/seed_*/checkpoint.msgpack")}
        calls.append(
            {"code": code, "lines": printed.getvalue().splitlines(), "mtimes": checkpoints}
        )
    return {"out": out, "config": config, "calls": calls, "args": args}


@pytest.mark.slow
def test_every_arm_and_seed_in_its_folder(ablation: dict) -> None:
    out, first = ablation["out"], ablation["calls"][0]
    assert first["code"] == 0
    for arm in ARMS:
        for seed in (0, 1):
            folder = out / arm.replace("+", "_") / f"seed_{seed}"
            for name in ("config.toml", "checkpoint.msgpack", "summary.json", "eval.csv"):
                assert (folder / name).is_file(), folder / name
            assert TrainConfig.from_toml(folder / "config.toml").run.seed == seed
            summary = json.loads((folder / "summary.json").read_text())
            assert summary["iterations"] == ITERATIONS
    for name in ("ablation.json", "ablation.md", "ablation.png", "ablation_curves.png"):
        assert (out / name).stat().st_size > 100
    starts = [line.split(" (run")[0] for line in first["lines"] if ": starting in " in line]
    assert starts == [f"{arm} seed {s}" for s in (0, 1) for arm in ARMS][1:]  # seed-major
    assert "walk+flight seed 0 (run 1 of 8): resuming in " in first["lines"][0]
    resumed = out / "walk_flight" / "seed_0"
    assert f"resumed {resumed} at iteration 1" in first["lines"]
    iterations = [int(r.split(",")[0]) for r in (resumed / "train.csv").read_text().split()[1:]]
    assert iterations == [1, 2]  # one before the interruption, one after
    assert any(line.startswith("ablation: 8 of 8 runs finished (") for line in first["lines"])


@pytest.mark.slow
def test_a_second_call_trains_nothing(ablation: dict) -> None:
    first, second = ablation["calls"]
    assert second["code"] == 0
    assert second["mtimes"] == first["mtimes"] and len(first["mtimes"]) == 8
    kept = [line for line in second["lines"] if ": kept, finished at iteration 2 in " in line]
    assert len(kept) == 8
    assert not any("starting" in line or "resuming" in line for line in second["lines"])
    from motionkit.cli import main

    with contextlib.redirect_stderr(io.StringIO()) as error:
        assert main(ablation["args"]) == 2  # without --resume: refused
    assert "holds ablation runs already" in error.getvalue() and "--resume" in error.getvalue()


@pytest.mark.slow
def test_the_table_from_the_written_evaluations(ablation: dict) -> None:
    out = ablation["out"]
    saved = json.loads((out / "ablation.json").read_text())
    table = (out / "ablation.md").read_text()
    for arm in ARMS:
        evaluations = [
            json.loads((run_folder(out, arm, s) / "summary.json").read_text())["eval"]
            for s in (0, 1)
        ]
        assert [saved["runs"][arm][str(s)]["eval"] for s in (0, 1)] == evaluations
        waypoints = [e["eval_waypoints_per_episode"] for e in evaluations]
        thrust = [1.0 - e["eval_thrust_usage"] for e in evaluations]
        duration = [e["eval_episode_seconds"] / 2.0 for e in evaluations]  # tiny: 2 s episodes
        for column, values in [
            ("waypoints per episode", waypoints),
            (RADAR[2], thrust),
            (RADAR[0], duration),
        ]:
            stats = saved["statistics"][arm][column]
            assert stats["mean"] == pytest.approx(np.mean(values), rel=1e-6)
            assert stats["min"] == pytest.approx(min(values), rel=1e-6)
            assert stats["max"] == pytest.approx(max(values), rel=1e-6)
        row = next(line for line in table.splitlines() if line.startswith(f"| {arm} |"))
        cells = row.split(" | ")
        assert cells[1] == "2 of 2"
        mean, low, high = np.mean(waypoints), min(waypoints), max(waypoints)
        assert cells[2 + list(TABLE).index("waypoints per episode")] == (
            f"{mean:.3g} [{low:.3g}, {high:.3g}]"
        )


@pytest.mark.slow
def test_priors_dropped_from_the_saved_configs(ablation: dict) -> None:
    out = ablation["out"]
    none = TrainConfig.from_toml(run_folder(out, "none", 0) / "config.toml")
    assert none.priors == {} and all(not s.priors for s in none.curriculum.values())
    flight = TrainConfig.from_toml(run_folder(out, "flight", 1) / "config.toml")
    assert list(flight.priors) == ["flight"]
    assert flight.curriculum["both"].priors == {"flight": 0.5}
    walk = TrainConfig.from_toml(run_folder(out, "walk", 0) / "config.toml")
    assert walk.curriculum["both"].priors == {"walk": 2.0} and walk.curriculum["later"].priors == {}
    summary = json.loads((run_folder(out, "none", 1) / "summary.json").read_text())
    assert summary["priors"] == {}


@pytest.mark.slow
def test_the_time_of_a_call_stops_a_real_run(
    ablation: dict, robot: Robot, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """With more iterations and 60 microseconds for the call, the first run resumes, stops at its
    max_minutes before an iteration (its setup takes longer; saved and evaluated), and no
    other run starts (the ablation's clock stands still until that run returns)."""
    import motionkit.train.ablation as module
    import motionkit.train.runner as runner

    now = [0.0]
    train, minutes = runner.train, []

    def timed_train(config: TrainConfig, out: Path, robot: Robot, **options: object) -> dict:
        minutes.append(config.run.max_minutes)
        summary = train(config, out, robot, **options)
        now[0] += 1.0  # the call's budget is spent
        return summary

    monkeypatch.setattr(module, "_clock", lambda: now[0])
    monkeypatch.setattr(runner, "train", timed_train)
    out = tmp_path / "ablation"
    shutil.copytree(ablation["out"], out)
    config = ablation["config"]
    more = replace(config, run=replace(config.run, iterations=ITERATIONS + 1))
    before = {p: p.stat().st_mtime_ns for p in out.glob("*/seed_*/checkpoint.msgpack")}
    lines: list[str] = []
    result = run_ablation(
        more, out, robot, [0, 1], resume=True, max_minutes=1e-6, progress=lines.append
    )  # 60 microseconds: less than any run's setup, however fast the machine
    assert minutes == [pytest.approx(1e-6)]
    assert "walk+flight seed 0 (run 1 of 8): resuming in " in lines[0]
    assert any(line.startswith("stopped after 1e-06 minutes") for line in lines)  # the runner's
    assert "walk+flight seed 0 (run 1 of 8): stopped at iteration 2 of 3" in " ".join(lines)
    assert "the time of this call is spent before walk seed 0 (run 2 of 8)" in lines[-2]
    after = {p: p.stat().st_mtime_ns for p in out.glob("*/seed_*/checkpoint.msgpack")}
    changed = [p for p in after if after[p] != before[p]]
    assert changed == [run_folder(out, "walk+flight", 0) / "checkpoint.msgpack"]
    assert result["finished"] == 0


def test_help_and_command_line_refusals(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from motionkit import recipes
    from motionkit.cli import main

    with pytest.raises(SystemExit):
        main(["train", "ablation", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    for needle in ("--seeds", "--max-minutes", "--resume", "seed_<s>", "seed-major"):
        assert needle in text
    for needle in ("ablation_curves.png", "1 - T/T_max", "mean [min, max]", "is refused"):
        assert needle in text
    args = ["train", "ablation", "--config", str(recipes.find("train", "tiny_cpu"))]
    args += ["--out", str(tmp_path / "out")]
    with pytest.raises(SystemExit):
        main([*args, "--seeds", "0,0"])
    assert "expected distinct seeds >= 0" in capsys.readouterr().err
    assert main([*args, "--seeds", "0,1", "--seed", "2"]) == 2
    assert "pass --seeds or --seed, not both" in capsys.readouterr().err
    assert main([*args, "--max-minutes", "-1"]) == 2
    assert "--max-minutes -1.0: expected >= 0" in capsys.readouterr().err
    assert not (tmp_path / "out").exists()
