"""`motionkit pipeline`: stage caching, recipe checks, and the whole chain on tiny recipes."""

import json
from pathlib import Path

import pytest
from mocap_synth import arms_down, mini_bvh

from motionkit import recipes
from motionkit.cli import main
from motionkit.core.errors import PipelineError
from motionkit.dataset import read
from motionkit.files.digests import digest
from motionkit.pipeline import run_pipeline
from motionkit.pipeline.cache import run_cached
from motionkit.pipeline.config import PipelineConfig
from motionkit.robot import load_robot

REPO = Path(__file__).resolve().parents[2]


def test_run_cached_reruns_only_for_a_new_key(tmp_path: Path) -> None:
    calls = []

    def work(folder: Path) -> str:
        calls.append(folder)
        (folder / "made.txt").write_text(str(len(calls)))
        return f"call {len(calls)}"

    out, records = tmp_path / "stage", tmp_path / "records"
    first = run_cached("s", "k1", out, records, work)
    again = run_cached("s", "k1", out, records, work)
    assert (first.status, again.status) == ("ran", "cached")
    assert again.made == "call 1" and len(calls) == 1
    changed = run_cached("s", "k2", out, records, work)
    assert changed.status == "ran" and (out / "made.txt").read_text() == "2"
    assert run_cached("s", "k2", out, records, work, force=True).status == "ran"
    assert len(calls) == 3


def test_failed_stage_keeps_the_previous_output(tmp_path: Path) -> None:
    out, records = tmp_path / "stage", tmp_path / "records"

    def good(folder: Path) -> str:
        (folder / "good.txt").write_text("1")
        return "ok"

    run_cached("s", "k1", out, records, good)
    record = (records / "s.json").read_text()

    def fail(folder: Path) -> str:
        (folder / "half.txt").write_text("partial")
        raise PipelineError("boom")

    with pytest.raises(PipelineError, match="boom"):
        run_cached("s", "k2", out, records, fail)
    assert sorted(p.name for p in out.iterdir()) == [".motionkit-files.json", "good.txt"]
    assert (records / "s.json").read_text() == record
    assert list((tmp_path / ".staging").iterdir()) == []
    assert run_cached("s", "k1", out, records, fail).status == "cached"


def test_digest_depends_on_every_part() -> None:
    assert digest("a", {"x": 1}) == digest("a", {"x": 1})
    assert digest("a", {"x": 1}) != digest("a", {"x": 2})
    assert digest("a", [1, 2]) != digest("a", [2, 1])


def test_the_shipped_recipe_names_existing_files() -> None:
    config = PipelineConfig.from_toml(recipes.find("pipeline", "tiny_cpu"))
    assert len(config.trajopt.recipes) == 1 and config.train.jet == "lstm"
    assert (
        config.resolve("trajopt", config.trajopt.library)
        == recipes.ROOT / "trajopt" / "library.toml"
    )
    assert config.resolve("retarget", config.retarget.recipe).parent == recipes.ROOT / "retarget"


def test_recipe_errors_name_the_key(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    recipe = tiny_recipes(tmp_path)
    text = recipe.read_text()
    recipe.write_text(text.replace('"takeoff.toml"', '"takeoff.toml", "missing.toml"'))
    with pytest.raises(
        PipelineError,
        match=r"\[trajopt\] recipes or library: missing.toml: no such file, nor a built-in",
    ):
        PipelineConfig.from_toml(recipe)
    recipe.write_text(text.replace('"takeoff.toml"', '"landing"'))  # a built-in, by name
    named = PipelineConfig.from_toml(recipe)
    assert named.resolve("trajopt", "landing") == recipes.ROOT / "trajopt" / "landing.toml"
    recipe.write_text(text.replace('recipe = "jet.toml"', ""))
    with pytest.raises(PipelineError, match=r"\[jet_ident\] recipe is missing"):
        PipelineConfig.from_toml(recipe)
    recipe.write_text("[trajectory]\n")
    assert main(["pipeline", "--config", str(recipe), "--out", str(tmp_path / "o")]) == 2
    assert "unknown keys ['trajectory']" in capsys.readouterr().err
    with pytest.raises(SystemExit) as exit:
        main(["pipeline", "--config", str(tmp_path / "none.toml")])
    assert exit.value.code == 2
    assert "none.toml: no such file, nor a built-in pipeline recipe" in capsys.readouterr().err
    assert not (tmp_path / "o").exists()


TINY_JET = """
[bench]
duration_s = 60.0
train_seeds = [1]
[model]
hidden = {hidden}
[train]
warmup = 10
window = 60
batch = 8
max_steps = 20
eval_every = 10
"""

TINY_TRAIN = """
[env]
episode_seconds = 0.5
[ppo]
num_envs = 4
rollout_steps = 4
epochs = 1
minibatch_size = 16
actor_hidden = [16]
critic_hidden = [16]
[amp]
hidden = [16]
batch_size = 16
buffer_size = 64
[run]
iterations = 1
eval_every = 0
eval_rollouts = 1
"""


def tiny_recipes(folder: Path, hidden: int = 8) -> Path:
    """A pipeline recipe with the smallest stage recipes that still run every stage."""
    (folder / "retarget.toml").write_text('kind = "walk"\n')
    # the recipe's 20 knots: coarser plans resampled at 50 Hz fail the datasets stage's checks
    (folder / "takeoff.toml").write_text(recipes.find("trajopt", "takeoff").read_text())
    (folder / "jet.toml").write_text(TINY_JET.format(hidden=hidden))
    (folder / "train.toml").write_text(TINY_TRAIN)
    recipe = folder / "pipeline.toml"
    recipe.write_text(
        '[retarget]\nrecipe = "retarget.toml"\njobs = 1\n'
        '[trajopt]\nrecipes = ["takeoff.toml"]\nreplay = false\n'
        '[jet_ident]\nrecipe = "jet.toml"\n'
        '[train]\nrecipe = "train.toml"\nfull_recipe = "train.toml"\n'
    )
    return recipe


def statuses(out: Path) -> dict[str, str]:
    summary = json.loads((out / "pipeline_summary.json").read_text())
    return {stage["stage"]: stage["status"] for stage in summary["stages"]}


@pytest.mark.slow
def test_pipeline_end_to_end_then_cached(tmp_path: Path, capsys) -> None:
    pytest.importorskip("placo")
    pytest.importorskip("casadi")
    pytest.importorskip("mujoco.mjx")
    mocap = tmp_path / "mocap"
    mocap.mkdir()
    (mocap / "walk.bvh").write_text(mini_bvh(arms_down(40)))
    recipe, out = tiny_recipes(tmp_path), tmp_path / "out"
    argv = ["pipeline", "--config", str(recipe), "--out", str(out), "--mocap-dir", str(mocap)]

    assert main(argv) == 0
    assert set(statuses(out).values()) == {"ran"}
    assert [p.name for p in (out / "walk").glob("*.mcap")] == ["walk.mcap"]
    assert (out / "flight" / "takeoff.mcap").is_file() and (out / "jet" / "model.npz").is_file()
    index = json.loads((out / "datasets" / "index.json").read_text())
    assert sorted(row["kind"] for row in index["clips"]) == ["takeoff", "walk"]
    trained = json.loads((out / "train" / "summary.json").read_text())
    assert trained["iterations"] == 1
    config = (out / "train" / "config.toml").read_text()
    assert 'jet = "lstm"' in config and str(out / "jet" / "model.npz") in config
    assert str(out / "walk") in config and str(out / "flight") in config
    text = capsys.readouterr().out
    assert "motionkit view" in text and "stage" in text
    assert "CoP in 1" in text  # the datasets stage's physics table, a line per clip

    stamp = (out / "train" / "summary.json").stat().st_mtime_ns
    assert main(argv) == 0  # nothing changed: every stage cached
    assert set(statuses(out).values()) == {"cached"}
    assert (out / "train" / "summary.json").stat().st_mtime_ns == stamp

    tiny_recipes(tmp_path, hidden=6)  # the jet recipe changed: only jet_ident runs again
    assert main([*argv, "--until", "jet_ident"]) == 0
    assert statuses(out) == {"retarget": "cached", "trajopt": "cached", "jet_ident": "ran"}

    (mocap / "broken.bvh").write_text("HIERARCHY\nROOT Hips\n{\n")  # a malformed input
    assert main([*argv, "--until", "retarget"]) == 2
    err = capsys.readouterr().err
    assert "broken.bvh" in err
    assert [p.name for p in (out / "walk").glob("*.mcap")] == ["walk.mcap"]  # the previous run's
    assert (out / ".pipeline" / "retarget.json").exists()


def test_every_stage_of_a_run_gets_its_robot(
    tmp_path: Path, toy_robot_files: tuple[Path, Path], monkeypatch: pytest.MonkeyPatch
) -> None:
    """The toy biped through retarget (recorded, not solved: the toy has one arm) and trajopt,
    whose take-off is written for it; another robot is another key."""
    pytest.importorskip("casadi")
    import motionkit.retarget.batch as batch

    monkeypatch.setenv("MOTIONKIT_TRAJOPT_COMPILE", "-O0")  # seconds, not minutes
    given = []
    monkeypatch.setattr(batch, "run_retarget", lambda *a, **k: given.append(a[4]) or [])
    mocap = tmp_path / "mocap"
    mocap.mkdir()
    (mocap / "walk.bvh").write_text(mini_bvh(arms_down(40)))
    config = PipelineConfig.from_toml(tiny_recipes(tmp_path))
    robot, out = load_robot(*toy_robot_files), tmp_path / "out"
    outcomes = run_pipeline(config, out, robot, mocap_dir=mocap, until="trajopt")
    assert [o.status for o in outcomes] == ["ran", "ran"] and given == [robot]
    clip = read(out / "flight" / "takeoff.mcap")
    assert (clip.metadata.robot, clip.metadata.robot_hash) == ("toy", robot.model_hash)
    assert clip.joint_positions.shape[1] == 7 and clip.thrust.shape[1] == 2
    summary = json.loads((out / "pipeline_summary.json").read_text())
    assert (summary["robot"], summary["robot_hash"]) == ("toy", robot.model_hash)

    again = run_pipeline(config, out, robot, mocap_dir=mocap, until="retarget")
    assert again[0].status == "cached"
    heavier = toy_robot_files[0].with_name("heavier.urdf")
    heavier.write_text(
        toy_robot_files[0].read_text().replace('mass value="4.0"', 'mass value="5.0"')
    )
    other = run_pipeline(config, out, load_robot(heavier, toy_robot_files[1]), mocap_dir=mocap,
                         until="retarget")  # fmt: skip
    assert other[0].status == "ran" and given[-1].total_mass == pytest.approx(12.0)


def test_cluster_goes_to_the_retarget_and_library_batches(
    tmp_path: Path, toy_robot_files: tuple[Path, Path], monkeypatch: pytest.MonkeyPatch
) -> None:
    """--cluster reaches run_retarget and solve_library (recorded, not run); it is not part of
    the stages' keys: the same outputs from a cluster or from local processes."""
    import motionkit.retarget.batch as batch
    import motionkit.trajopt.runner as runner

    calls: list[tuple[str, object]] = []
    monkeypatch.setattr(
        batch, "run_retarget", lambda *a, **k: calls.append(("retarget", a[5])) or []
    )

    def solve_batch(tasks: list, configs: list, cache: Path, *args: object, **kwargs: object):
        calls.append(("library", kwargs["cluster"]))
        cache.mkdir(parents=True, exist_ok=True)
        for name in runner.clip_files(t.name for t in tasks):
            (cache / name).write_text(name)
        figures = dict.fromkeys(runner.FIGURES, 1.0)
        return [runner.Outcome(t.name, True, "solved", figures) for t in tasks]

    monkeypatch.setattr(runner, "solve_batch", solve_batch)
    mocap = tmp_path / "mocap"
    mocap.mkdir()
    (mocap / "walk.bvh").write_text(mini_bvh(arms_down(40)))
    recipe = tiny_recipes(tmp_path)
    text = recipe.read_text().replace(
        'recipes = ["takeoff.toml"]', 'recipes = []\nlibrary = "library"'
    )
    recipe.write_text(text)
    config, robot = PipelineConfig.from_toml(recipe), load_robot(*toy_robot_files)
    first = run_pipeline(config, tmp_path / "a", robot, mocap_dir=mocap, until="trajopt",
                         cluster="10.0.0.5:6379")  # fmt: skip
    assert calls == [("retarget", "10.0.0.5:6379"), ("library", "10.0.0.5:6379")]
    local = run_pipeline(config, tmp_path / "b", robot, mocap_dir=mocap, until="trajopt")
    assert calls[2:] == [("retarget", None), ("library", None)]
    assert [o.key for o in first] == [o.key for o in local]
    assert len(list((tmp_path / "a" / "flight").glob("*.mcap"))) == 43
