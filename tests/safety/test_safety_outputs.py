"""Nothing a user has is lost: a failing pipeline rerun keeps the previous output, --out folders
holding the user's own files are refused (or left alone), a bad simulation or a corrupt
checkpoint writes nothing, and an --out that is a file or read-only is refused before the
work."""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path

import pytest
from safety_support import read_only_folder, snapshot, walk_bvh

from motionkit import recipes
from motionkit.cli import main
from motionkit.core.errors import PipelineError
from motionkit.files.outputs import MANIFEST, record_names
from motionkit.pipeline.cache import run_cached


def no_work(*args: object, **kwargs: object) -> None:
    raise AssertionError("the long work started")


def no_work_stage(ctx: object) -> None:
    """A pipeline stage that passes the dry run (recipes checked before OUT is made) and
    fails if it is asked to do its work."""
    from motionkit.pipeline.stages import DryRun

    if not isinstance(ctx, DryRun):
        no_work()


def pipeline_recipe(folder: Path) -> Path:
    """A pipeline recipe whose retarget stage runs in this process (jobs = 1)."""
    (folder / "retarget.toml").write_text('kind = "walk"\n')
    recipe = folder / "pipeline.toml"
    recipe.write_text(
        '[retarget]\nrecipe = "retarget.toml"\njobs = 1\n'
        '[trajopt]\nrecipes = ["takeoff"]\n[jet_ident]\nrecipe = "p250"\n'
        '[train]\nrecipe = "tiny_cpu"\nfull_recipe = "tiny_cpu"\n'
    )
    return recipe


def test_failing_pipeline_rerun_keeps_the_previous_output(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    pytest.importorskip("placo")
    mocap, out = tmp_path / "mocap", tmp_path / "out"
    walk_bvh(mocap / "walk.bvh")
    argv = ["pipeline", "--config", str(pipeline_recipe(tmp_path)), "--out", str(out),
            "--mocap-dir", str(mocap), "--until", "retarget"]  # fmt: skip
    assert main(argv) == 0
    before = snapshot(out)
    assert "walk/walk.mcap" in before and ".pipeline/retarget.json" in before

    (mocap / "broken.bvh").write_text("HIERARCHY\nROOT Hips\n{\n")  # truncated
    assert main(argv) == 2
    assert "broken.bvh" in capsys.readouterr().err
    after = snapshot(out)
    assert {k: v for k, v in after.items() if k != "pipeline_summary.json"} == {
        k: v for k, v in before.items() if k != "pipeline_summary.json"
    }
    assert not any(k.startswith(".staging/walk") for k in after)


def test_stage_folder_with_a_user_file_is_refused(tmp_path: Path) -> None:
    out, records = tmp_path / "walk", tmp_path / ".pipeline"

    def work(folder: Path) -> str:
        (folder / "a.mcap").write_bytes(b"clip")
        return "one clip"

    assert run_cached("retarget", "k1", out, records, work).status == "ran"
    assert json.loads((out / MANIFEST).read_text()) == {"files": ["a.mcap"]}
    (out / "mine.mcap").write_bytes(b"the user's")
    with pytest.raises(PipelineError, match=r"walk holds mine\.mcap, not written by motionkit"):
        run_cached("retarget", "k2", out, records, no_work)
    assert (out / "mine.mcap").read_bytes() == b"the user's"
    assert (out / "a.mcap").read_bytes() == b"clip"


def test_pipeline_out_with_a_user_walk_folder_is_refused(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    import motionkit.pipeline.runner as runner

    monkeypatch.setattr(runner, "STAGES", (("retarget", no_work_stage),))
    out = tmp_path / "out"
    (out / "walk").mkdir(parents=True)
    (out / "walk" / "mine.mcap").write_bytes(b"the user's")
    code = main(["pipeline", "--config", str(pipeline_recipe(tmp_path)), "--out", str(out)])
    assert code == 2
    assert f"{out} holds walk, not written by motionkit" in capsys.readouterr().err
    assert snapshot(out) == {"walk/mine.mcap": b"the user's"}


def test_retarget_into_a_folder_of_the_users_clips(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    pytest.importorskip("placo")
    clip = walk_bvh(tmp_path / "in" / "walk.bvh", 12)
    out = tmp_path / "walk"
    out.mkdir()
    (out / "walk.mcap").write_bytes(b"the user's walk")
    assert main(["retarget", str(clip), "--out", str(out)]) == 2
    assert "holds walk.mcap, not written by motionkit" in capsys.readouterr().err
    assert snapshot(out) == {"walk.mcap": b"the user's walk"}

    (out / "walk.mcap").rename(out / "mine.mcap")  # another name: written beside it
    assert main(["retarget", str(clip), "--out", str(out)]) == 0
    assert main(["retarget", str(clip), "--out", str(out)]) == 0  # its own file: replaced
    files = snapshot(out)
    assert sorted(files) == [MANIFEST, "mine.mcap", "retarget_summary.json", "walk.mcap"]
    assert files["mine.mcap"] == b"the user's walk"
    assert json.loads(files[MANIFEST])["files"] == ["retarget_summary.json", "walk.mcap"]


# Each command's arguments: its inputs made in a folder, then --out.
def fit_argv(inputs: Path, out: Path) -> list[str]:
    return ["jet-ident", "fit", str(inputs / "log.csv"), "--out", str(out)]


def train_argv(inputs: Path, out: Path) -> list[str]:
    recipe = str(recipes.find("train", "tiny_cpu"))
    return ["train", "--config", recipe, "--out", str(out), "--priors", "none"]


def trajopt_argv(inputs: Path, out: Path) -> list[str]:
    return ["trajopt", "--scenario", "takeoff", "--name", "hop", "--quiet", "--out", str(out)]


def retarget_argv(inputs: Path, out: Path) -> list[str]:
    return ["retarget", str(walk_bvh(inputs / "walk.bvh", 12)), "--out", str(out)]


def pipeline_argv(inputs: Path, out: Path) -> list[str]:
    return ["pipeline", "--config", str(pipeline_recipe(inputs)), "--out", str(out)]


# command -> (its arguments, what does the long work (replaced by a failure), an output name)
COMMANDS: dict[str, tuple[Callable[[Path, Path], list[str]], str, str]] = {
    "retarget": (retarget_argv, "motionkit.retarget.batch.retarget_all", "walk.mcap"),
    "trajopt": (trajopt_argv, "motionkit.trajopt.solve.solve", "hop.mcap"),
    "jet-ident fit": (fit_argv, "motionkit.jet_ident.fit.identify", "report.txt"),
    "train": (train_argv, "motionkit.train.runner.load_priors", "train.csv"),
    "pipeline": (pipeline_argv, "motionkit.pipeline.runner.STAGES", "walk"),
}


def refused(
    command: str,
    inputs: Path,
    out: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> str:
    """Run `command` into `out` with its long work replaced by a failure; its error line."""
    argv, work, _ = COMMANDS[command]
    if command == "train":
        pytest.importorskip("mujoco.mjx")
        import motionkit.train.runner  # noqa: F401  (so that its load_priors can be replaced)
    if command in ("trajopt", "pipeline"):
        pytest.importorskip("casadi")
    if command == "jet-ident fit":
        pytest.importorskip("optax")
    arguments = argv(inputs, out)
    stand_in = (("retarget", no_work_stage),) if work.endswith("STAGES") else no_work
    monkeypatch.setattr(work, stand_in)
    assert main(arguments) == 2
    err = capsys.readouterr().err
    assert err.startswith("motionkit: error: ") and err.count("\n") == 1, err
    return err


@pytest.mark.parametrize("command", COMMANDS)
def test_out_that_is_a_file_is_refused_before_the_work(
    command: str,
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    out = tmp_path / "results"
    out.write_bytes(b"the user's file")
    assert f"{out}: is a file, not a folder" in refused(command, tmp_path, out, monkeypatch, capsys)
    assert out.read_bytes() == b"the user's file"


@pytest.mark.parametrize("command", COMMANDS)
def test_read_only_out_is_refused_before_the_work(
    command: str,
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    out = read_only_folder(tmp_path)
    before = sorted(p.name for p in out.iterdir())
    assert f"{out}: cannot write there" in refused(command, tmp_path, out, monkeypatch, capsys)
    assert sorted(p.name for p in out.iterdir()) == before


@pytest.mark.parametrize("command", COMMANDS)
def test_out_holding_a_users_file_of_an_output_name_is_refused(
    command: str,
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    out = tmp_path / "results"
    name = COMMANDS[command][2]
    out.mkdir()
    (out / name).write_bytes(b"the user's")
    assert f"holds {name}, not written by motionkit" in refused(
        command, tmp_path, out, monkeypatch, capsys
    )
    assert snapshot(out) == {name: b"the user's"}


def test_simulate_with_a_bad_config_keeps_the_good_csv(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    pytest.importorskip("optax")
    csv = tmp_path / "p250.csv"
    argv = ["jet-ident", "simulate", "--out", str(csv), "--duration", "10"]
    assert main(argv) == 0
    good = csv.read_bytes()
    bad = tmp_path / "bad.toml"  # 20 kHz: the CSV's 0.1 ms times would repeat
    bad.write_text("[bench]\nrate_hz = 20000.0\n")
    assert main([*argv, "--config", str(bad), "--seed", "3"]) == 2
    assert "(not written): line" in capsys.readouterr().err
    assert csv.read_bytes() == good
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bad.toml", "p250.csv"]

    assert main(["jet-ident", "simulate", "--out", str(tmp_path)]) == 2  # a folder
    assert "is a folder; give the CSV file" in capsys.readouterr().err


def test_resume_with_a_corrupt_checkpoint_writes_nothing(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    pytest.importorskip("mujoco.mjx")
    from motionkit.train.runner import OUTPUTS

    out = tmp_path / "run"
    out.mkdir()
    (out / "checkpoint.msgpack").write_bytes(b"\x93not a checkpoint")
    record_names(out, OUTPUTS)  # as a run leaves it
    before = snapshot(out)
    assert main([*train_argv(tmp_path, out), "--resume"]) == 2
    assert "checkpoint.msgpack: not a checkpoint (unreadable msgpack" in capsys.readouterr().err
    assert snapshot(out) == before
