"""The pipeline's trajopt stage keeps its solved clips: each is written into the stage's clip
cache (OUT/.pipeline/trajopt_clips) as it is solved, a failed stage leaves them there, and the
next run solves only what is missing. The stage succeeds when every recipe flight and, of each
kind of library clip, at least [trajopt] min_solved_share solved; it names the failed clips.
The solver is a stand-in that counts its calls (the batch runs in this process)."""

from __future__ import annotations

import contextlib
import json
from collections.abc import Collection, Iterator
from pathlib import Path
from typing import Any

import pytest
from mocap_synth import arms_down, mini_bvh

from motionkit import recipes
from motionkit.core.errors import PipelineError, TrajoptError
from motionkit.pipeline import run_pipeline
from motionkit.pipeline.config import PipelineConfig
from motionkit.robot.model import ironcub
from motionkit.runtime.executors import InProcess
from motionkit.trajopt import runner

LIBRARY = """
[[entries]]
name = "up"
recipe = "takeoff"
grid = [[0.0], [0.0], [0.8, 1.0]]

[[entries]]
name = "hop"
recipe = "jet_jump"
targets = [[-0.3, 0.0, 0.0], [0.3, 0.0, 0.0]]
"""
CLIPS = ["takeoff", "up_+0p00_+0p00_+0p80", "up_+0p00_+0p00_+1p00"]
CLIPS += ["hop_-0p30_+0p00_+0p00", "hop_+0p30_+0p00_+0p00"]
FAILING = "hop_+0p30_+0p00_+0p00"


class StandIn:
    """solve_files without IPOPT: records the names it solves, fails those in `fail`."""

    def __init__(self, fail: Collection[str] = ()) -> None:
        self.solved: list[str] = []
        self.fail = set(fail)

    def __call__(self, config: Any, name: str, *args: Any, **kwargs: Any) -> tuple[dict, dict]:
        self.solved.append(name)
        if name in self.fail:
            raise TrajoptError(f"scenario 'jet_jump' is infeasible or unsolved ({name})")
        metrics = {
            "status": "Solve_Succeeded", "iterations": 40, "solve_s": 2.0, "build_s": 0.1,
            "variables": 100, "constraints": 90, "target_error_m": 0.0,
            "complementarity_violation_nm": 0.0, "residual_dynamics": 0.0,
            "duration_s": 2.0, "airborne_s": 1.0,
        }  # fmt: skip
        document = json.dumps({"config": config.to_dict(), "metrics": metrics})
        return metrics, {
            f"{name}.knots.npz": b"knots",
            f"{name}.config.json": document.encode(),
            f"{name}.mcap": b"clip",
        }


@contextlib.contextmanager
def in_process(*args: Any, **kwargs: Any) -> Iterator[InProcess]:
    yield InProcess()


def pipeline(folder: Path, share: float | None = None) -> PipelineConfig:
    """A pipeline recipe whose trajopt stage solves the take-off recipe and LIBRARY."""
    trajopt = recipes.ROOT / "trajopt"
    for name in ("takeoff", "jet_jump"):
        (folder / f"{name}.toml").write_text((trajopt / f"{name}.toml").read_text())
    (folder / "library.toml").write_text(LIBRARY)
    (folder / "jet.toml").write_text("[bench]\ntrain_seeds = [1]\n")
    (folder / "train.toml").write_text("")
    (folder / "retarget.toml").write_text('kind = "walk"\n')
    extra = f"min_solved_share = {share}\n" if share else ""
    recipe = folder / "pipeline.toml"
    recipe.write_text(
        '[retarget]\nrecipe = "retarget.toml"\n'
        '[trajopt]\nrecipes = ["takeoff.toml"]\nlibrary = "library.toml"\nreplay = false\n'
        + extra
        + '[jet_ident]\nrecipe = "jet.toml"\n'
        '[train]\nrecipe = "train.toml"\nfull_recipe = "train.toml"\n'
    )
    return PipelineConfig.from_toml(recipe)


@pytest.fixture
def mocap(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """Retargeting recorded, not run; the solves in this process."""
    pytest.importorskip("casadi")
    import motionkit.retarget.batch as batch

    monkeypatch.setattr(batch, "run_retarget", lambda *a, **k: [])
    monkeypatch.setattr(runner, "open_executor", in_process)
    folder = tmp_path / "mocap"
    folder.mkdir()
    (folder / "walk.bvh").write_text(mini_bvh(arms_down(40)))
    return folder


def mcaps(folder: Path) -> list[str]:
    return sorted(p.stem for p in folder.glob("*.mcap"))


def test_failed_stage_keeps_its_solved_clips_for_the_next_run(
    tmp_path: Path, mocap: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    config, robot, out = pipeline(tmp_path), ironcub(), tmp_path / "out"
    first = StandIn(fail={FAILING})
    monkeypatch.setattr(runner, "solve_files", first)
    with pytest.raises(PipelineError) as error:
        run_pipeline(config, out, robot, mocap_dir=mocap, until="trajopt")
    message = str(error.value)
    assert message.startswith("stage trajopt failed after ")
    assert "1 of 2 jump clips solved (at least 75% needed)" in message
    assert f"{FAILING}: scenario 'jet_jump' is infeasible or unsolved" in message
    assert "4 solved clips kept in" in message and "\n" not in message
    assert first.solved == CLIPS
    cache = out / ".pipeline" / "trajopt_clips"
    assert mcaps(cache) == sorted(set(CLIPS) - {FAILING})
    assert not (out / "flight").exists() and not (out / ".pipeline" / "trajopt.json").exists()

    again = StandIn()
    monkeypatch.setattr(runner, "solve_files", again)
    outcomes = run_pipeline(config, out, robot, mocap_dir=mocap, until="trajopt")
    assert again.solved == [FAILING]  # the four solved before are kept
    assert outcomes[1].status == "ran"
    assert outcomes[1].made == (
        "1 flight(s) (takeoff) and 4 of 4 library clips (4 s airborne), IPOPT 10 s, checked"
    )
    assert mcaps(out / "flight") == sorted(CLIPS)
    assert (out / "flight" / "takeoff.mcap").read_bytes() == b"clip"

    forced = StandIn(fail=CLIPS)  # would fail every clip: none is solved again
    monkeypatch.setattr(runner, "solve_files", forced)
    outcomes = run_pipeline(config, out, robot, mocap_dir=mocap, until="trajopt", force=True)
    assert forced.solved == [] and outcomes[1].status == "ran"


def test_stage_with_a_failed_clip_succeeds_when_enough_of_its_kind_solved(
    tmp_path: Path, mocap: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    config, robot, out = pipeline(tmp_path, share=0.5), ironcub(), tmp_path / "out"
    monkeypatch.setattr(runner, "solve_files", StandIn(fail={FAILING}))
    lines: list[str] = []
    outcomes = run_pipeline(config, out, robot, mocap_dir=mocap, until="trajopt",
                            progress=lines.append)  # fmt: skip
    made = outcomes[1].made
    assert made.startswith("1 flight(s) (takeoff) and 3 of 4 library clips (3 s airborne), ")
    assert made.endswith(f"; 1 failed: {FAILING} (--force retries)")
    assert f"trajopt: {FAILING} failed: scenario 'jet_jump' is infeasible or unsolved" in "\n".join(
        lines
    )
    assert mcaps(out / "flight") == sorted(set(CLIPS) - {FAILING})
    summary = json.loads((out / "pipeline_summary.json").read_text())
    assert summary["stages"][1]["made"] == made


def test_a_failed_recipe_flight_fails_the_stage(
    tmp_path: Path, mocap: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    config, robot, out = pipeline(tmp_path, share=0.5), ironcub(), tmp_path / "out"
    monkeypatch.setattr(runner, "solve_files", StandIn(fail={"takeoff"}))
    with pytest.raises(PipelineError, match=r"trajopt: flight 'takeoff' failed; failed: takeoff"):
        run_pipeline(config, out, robot, mocap_dir=mocap, until="trajopt")


def test_min_solved_share_is_checked(tmp_path: Path) -> None:
    with pytest.raises(PipelineError, match="'min_solved_share' should be finite and in"):
        pipeline(tmp_path, share=1.5)
