"""benchmarks/gpu_runs.sh end to end on a CPU: a tiny walking run within its budget, its
strict-JSON report and text summary, a flying run resumed from its slim checkpoint with the jets
at rest (the GPU recipes' ladder), and the refusals (a missing prior folder, a run folder that
holds a run, jets at rest without another run's checkpoint). Two training subprocesses."""

import importlib.util
import json
import os
import shutil
import subprocess
import zipfile
from pathlib import Path
from typing import Any

import pytest

pytestmark = pytest.mark.slow

ROOT = Path(__file__).resolve().parents[2]
SCRIPT = ROOT / "benchmarks" / "gpu_runs.sh"
RECIPE, NEXT = "walk_gpu", "fly_gpu"  # the second goes on from the first
TINY = ("--num-envs", "8", "--minibatch-size", "64", "--eval-rollouts", "2", "--eval-every", "0")
STEPS = 8 * 16  # num_envs x rollout_steps (the recipe's default 16)


def gpu_runs(*args: object, env: dict[str, str] | None = None) -> subprocess.CompletedProcess[str]:
    """The script as a user runs it, from the repository root, in this environment."""
    return subprocess.run(
        ["bash", str(SCRIPT), *map(str, args)],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=600,
        check=False,
        env=env,
    )


def explain(result: subprocess.CompletedProcess[str]) -> str:
    return f"exit {result.returncode}\n{result.stdout[-3000:]}\n{result.stderr[-3000:]}"


def strict_json(path: Path) -> dict[str, Any]:
    def refuse(constant: str) -> None:
        raise ValueError(f"{path}: {constant} is not strict JSON")

    return json.loads(path.read_text(), parse_constant=refuse)


@pytest.fixture(scope="module")
def priors_dir(prior_files: dict[str, Path], tmp_path_factory: pytest.TempPathFactory) -> Path:
    """DIR/walk and DIR/flight, one clip each, as --priors-dir expects."""
    folder = tmp_path_factory.mktemp("gpu_priors")
    for name, path in prior_files.items():
        (folder / name).mkdir()
        shutil.copy(path, folder / name / path.name)
    return folder


@pytest.fixture(scope="module")
def first_run(
    priors_dir: Path, tmp_path_factory: pytest.TempPathFactory
) -> tuple[Path, subprocess.CompletedProcess[str]]:
    out = tmp_path_factory.mktemp("gpu_run") / "out"
    result = gpu_runs(RECIPE, 3, "--priors-dir", priors_dir, "--out", out, *TINY, "--iterations", 2)
    return out, result


def test_gpu_run_writes_its_figures(first_run: tuple[Path, subprocess.CompletedProcess]) -> None:
    out, result = first_run
    assert result.returncode == 0, explain(result)
    report = strict_json(out / "gpu_run.json")
    assert report["status"] == "ok"
    assert report["recipe"] == RECIPE
    assert report["budget_minutes"] == 3
    assert 0.2 <= report["train_minutes"] <= 2.5
    assert report["iterations"] == 2
    assert report["env_steps"] == 2 * STEPS
    assert report["device"]["platform"] == "cpu"
    assert report["device"]["jax"] and report["device"]["mujoco"]
    assert report["train_csv"]["iteration"] == [1, 2]
    assert all(len(values) == 2 for values in report["train_csv"].values())
    assert report["eval_csv"]["iteration"] == [2]
    assert "eval_waypoints_per_episode" in report["final_evaluation"]
    assert report["throughput"]["env_steps_per_second"] > 0
    assert report["throughput"]["first_iteration_seconds"] > 0
    assert set(report["priors"]) == {"walk"}
    assert report["jets_at_rest"] is False
    text = (out / "gpu_run.txt").read_text()
    assert RECIPE in text
    assert "eval_waypoints_per_episode = " in text
    assert text in result.stdout  # printed at the end too
    sizes = report["checkpoint_bytes"]
    assert sizes["full"] == (out / "checkpoint.msgpack").stat().st_size
    assert sizes["slim"] == (out / "checkpoint_slim.msgpack").stat().st_size
    assert 0.3 < sizes["slim"] / sizes["full"] < 0.36  # Adam's two moments per parameter left out
    assert f"slim {sizes['slim'] / 1e6:.1f} MB" in text


def test_gpu_run_refuses_a_folder_that_holds_a_run(
    first_run: tuple[Path, subprocess.CompletedProcess], priors_dir: Path
) -> None:
    out, _ = first_run
    result = gpu_runs(RECIPE, 3, "--priors-dir", priors_dir, "--out", out, *TINY)
    assert result.returncode == 2, explain(result)
    errors = [line for line in result.stderr.splitlines() if line.startswith("error:")]
    assert len(errors) == 1, result.stderr
    assert f"--resume {out / 'checkpoint.msgpack'}" in errors[0]
    for resume in ((), ("--resume", out / "checkpoint.msgpack")):  # none, or the run's own
        args = ("--priors-dir", priors_dir, "--out", out, "--jets-at-rest", *resume, *TINY)
        result = gpu_runs(RECIPE, 3, *args)
        assert result.returncode == 2, explain(result)
        errors = [line for line in result.stderr.splitlines() if line.startswith("error:")]
        assert len(errors) == 1 and "--jets-at-rest" in errors[0], result.stderr


def test_gpu_run_goes_on_from_another_runs_checkpoint(
    first_run: tuple[Path, subprocess.CompletedProcess], priors_dir: Path, tmp_path: Path
) -> None:
    """Flying from walking's slim checkpoint, carried elsewhere as from another machine, into a
    new --out, the jets set at rest for the thrust set point."""
    out, first = first_run
    assert first.returncode == 0, explain(first)
    carried = tmp_path / "carried.msgpack"
    shutil.copy(out / "checkpoint_slim.msgpack", carried)
    resumed = tmp_path / "resumed"
    result = gpu_runs(
        NEXT, 3, "--priors-dir", priors_dir, "--out", resumed, *TINY, "--iterations", 3,
        "--resume", carried, "--jets-at-rest",
    )  # fmt: skip
    assert result.returncode == 0, explain(result)
    assert "at iteration 2 (a slim checkpoint: the optimisers' moments start afresh)" in (
        result.stdout
    )
    assert "the policy's jet outputs start at rest (thrust action)" in result.stdout
    report = strict_json(resumed / "gpu_run.json")
    assert report["jets_at_rest"] is True
    assert report["config"]["env"]["jet_action"] == "thrust"
    assert set(report["priors"]) == {"flight"}
    assert report["iterations"] == 3
    assert report["start_iteration"] == 2
    assert report["env_steps"] == 3 * STEPS
    assert report["train_csv"]["iteration"] == [3]
    assert report["eval_csv"]["iteration"] == [3]
    assert report["throughput"]["iterations_this_call"] == 1
    assert report["throughput"]["first_iteration_seconds"] > 0
    assert "eval_waypoints_per_episode" in report["final_evaluation"]
    assert (resumed / "checkpoint.msgpack").stat().st_size == report["checkpoint_bytes"]["full"]


def test_gpu_run_names_a_missing_prior_folder(prior_files: dict[str, Path], tmp_path: Path) -> None:
    (tmp_path / "priors" / "walk").mkdir(parents=True)
    shutil.copy(prior_files["walk"], tmp_path / "priors" / "walk")
    out = tmp_path / "out"
    result = gpu_runs("walk_fly_gpu", 3, "--priors-dir", tmp_path / "priors", "--out", out, *TINY)
    assert result.returncode == 2, explain(result)
    errors = [line for line in result.stderr.splitlines() if line.startswith("error:")]
    assert len(errors) == 1, result.stderr
    assert str(tmp_path / "priors" / "flight") in errors[0]
    assert not out.exists()


def _module() -> Any:
    spec = importlib.util.spec_from_file_location("gpu_run", ROOT / "benchmarks" / "gpu_run.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_gpu_run_budget_and_strict_json(tmp_path: Path) -> None:
    gpu_run = _module()
    assert gpu_run.train_minutes(8.0, 0.0) == pytest.approx(6.8)
    assert gpu_run.train_minutes(2.0, 0.0) == pytest.approx(1.5)  # a margin of 0.5 min at least
    assert gpu_run.train_minutes(1.0, 0.8) == pytest.approx(0.2)  # never below 0.2 min
    assert gpu_run.train_minutes(8.0, 0.0, 5.0) == pytest.approx(5.0)  # the recipe's own limit
    (tmp_path / "train.csv").write_text("iteration,a,b\n1,0.5,\n2,nan,3\n")
    columns = gpu_run.read_columns(tmp_path / "train.csv")
    assert columns == {"iteration": [1, 2], "a": [0.5, None], "b": [None, 3.0]}
    assert json.dumps(gpu_run.strict_json({"x": [float("inf"), 1.0]}), allow_nan=False) == (
        '{"x": [null, 1.0]}'
    )


def probe_wheel(folder: Path) -> Path:
    """A minimal pure-Python wheel: package `mkprobe`, one data file under share/, and a
    `sitecustomize` module that Python imports at start-up from its path (so it tells whether the
    prefix reached the script's PYTHONPATH)."""
    info = "mkprobe-0.1.dist-info"
    files = {
        "mkprobe/__init__.py": "VALUE = 7\n",
        "sitecustomize.py": "import sys\nprint('mkprobe on the path', file=sys.stderr)\n",
        "mkprobe-0.1.data/data/share/mkprobe/note.txt": "probe\n",
        f"{info}/METADATA": "Metadata-Version: 2.1\nName: mkprobe\nVersion: 0.1\n",
        f"{info}/WHEEL": "Wheel-Version: 1.0\nGenerator: test\nRoot-Is-Purelib: true\n"
        "Tag: py3-none-any\n",
    }
    files[f"{info}/RECORD"] = "".join(f"{name},,\n" for name in [*files, f"{info}/RECORD"])
    path = folder / "mkprobe-0.1-py3-none-any.whl"
    with zipfile.ZipFile(path, "w") as archive:
        for name, text in files.items():
            archive.writestr(name, text)
    return path


def test_gpu_run_installs_a_wheel_folder_first(tmp_path: Path) -> None:
    """--wheels DIR: DIR's wheels go under a prefix in TMPDIR, its site folder onto PYTHONPATH
    (the script's Python imports the package from there); an empty DIR is refused."""
    (tmp_path / "wheels").mkdir()
    env = os.environ | {"TMPDIR": str(tmp_path)}
    empty = gpu_runs("--wheels", tmp_path / "wheels", "--help", env=env)
    assert empty.returncode == 2, explain(empty)
    assert "no .whl files there" in empty.stderr
    probe_wheel(tmp_path / "wheels")
    result = gpu_runs("--wheels", tmp_path / "wheels", "--help", env=env)
    assert result.returncode == 0, explain(result)
    prefix = tmp_path / "motionkit-wheels"
    assert f"installed 1 wheels from {tmp_path / 'wheels'} into {prefix}" in result.stderr
    assert "usage: gpu_runs.sh" in result.stdout
    assert "mkprobe on the path" in result.stderr  # gpu_run.py's Python found the prefix
    installed = list(prefix.rglob("mkprobe/__init__.py"))
    assert len(installed) == 1 and installed[0].parent.parent.name.endswith("-packages")
    assert (prefix / "share" / "mkprobe" / "note.txt").read_text() == "probe\n"
