"""Solved work is kept: a library solve writes each clip as it is solved, so that after a failed
or interrupted run the rerun solves only the clips that are missing or out of date. The solver
is replaced by a stand-in that counts its calls (and the batch runs in this process, where the
stand-in is); the slow test at the end does the same with real solves."""

from __future__ import annotations

import contextlib
import json
from collections.abc import Collection, Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from motionkit import recipes
from motionkit.core.errors import TrajoptError
from motionkit.robot.model import ironcub
from motionkit.runtime.executors import InProcess
from motionkit.trajopt import runner
from motionkit.trajopt.config import TrajoptConfig
from motionkit.trajopt.runner import solve_library

RECIPES = recipes.ROOT / "trajopt"
NAMES = ("up_+0p00_+0p00_+0p80", "up_+0p00_+0p00_+1p00", "up_+0p00_+0p00_+1p20")
LIBRARY = '[[entries]]\nname = "up"\nrecipe = "takeoff"\ngrid = [[0.0], [0.0], [0.8, 1.0, 1.2]]\n'


def figures(name: str) -> dict[str, Any]:
    """The metrics a solved clip has (those a batch and its summary line read)."""
    return {
        "status": "Solve_Succeeded", "iterations": 40, "max_iter": 500, "retries": 0,
        "homotopy": [{"iterations": 30}, {"iterations": 10}], "solve_s": 1.5, "build_s": 0.1,
        "variables": 100, "constraints": 90, "target_error_m": 0.0,
        "complementarity_violation_nm": 0.0, "residual_dynamics": 0.0,
        "duration_s": 1.9, "airborne_s": 0.5 + NAMES.index(name) / 10,
    }  # fmt: skip


class StandIn:
    """solve_files without IPOPT: records the names it solves; `fail` names fail with a
    TrajoptError, `stop` names stop the run as Ctrl-C does."""

    def __init__(self, fail: Collection[str] = (), stop: Collection[str] = ()) -> None:
        self.solved: list[str] = []
        self.fail, self.stop = set(fail), set(stop)

    def __call__(
        self, config: TrajoptConfig, name: str, *args: Any, **kwargs: Any
    ) -> tuple[dict[str, Any], dict[str, bytes]]:
        if name in self.stop:
            raise KeyboardInterrupt
        self.solved.append(name)
        if name in self.fail:
            raise TrajoptError(f"scenario 'takeoff' is infeasible or unsolved ({name})")
        metrics = figures(name)
        document = {"config": config.to_dict(), "metrics": metrics}
        return metrics, {
            f"{name}.knots.npz": b"knots",
            f"{name}.config.json": json.dumps(document).encode(),
            f"{name}.mcap": b"clip",
        }


@contextlib.contextmanager
def in_process(*args: Any, **kwargs: Any) -> Iterator[InProcess]:
    yield InProcess()


@pytest.fixture
def library(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    monkeypatch.setattr(runner, "open_executor", in_process)
    (tmp_path / "takeoff.toml").write_text((RECIPES / "takeoff.toml").read_text())
    path = tmp_path / "library.toml"
    path.write_text(LIBRARY)
    return path


def stamps(out: Path) -> dict[str, int]:
    return {p.name: p.stat().st_mtime_ns for p in sorted(out.iterdir()) if p.suffix == ".mcap"}


def test_rerun_after_a_failed_clip_solves_only_that_clip(
    library: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    out, robot = tmp_path / "out", ironcub()
    first = StandIn(fail={NAMES[1]})
    monkeypatch.setattr(runner, "solve_files", first)
    outcomes = solve_library(library, out, robot, jobs=1, replay=False)
    assert [o.solved for o in outcomes] == [True, False, True]
    assert "infeasible or unsolved" in outcomes[1].text
    assert first.solved == list(NAMES)
    assert sorted(stamps(out)) == [f"{NAMES[0]}.mcap", f"{NAMES[2]}.mcap"]
    before = stamps(out)

    again = StandIn()
    monkeypatch.setattr(runner, "solve_files", again)
    lines: list[str] = []
    outcomes = solve_library(library, out, robot, jobs=1, replay=False, progress=lines.append)
    assert again.solved == [NAMES[1]]  # the two solved before are not solved again
    assert [o.solved for o in outcomes] == [True, True, True]
    assert [o.figures["airborne_s"] for o in outcomes] == pytest.approx([0.5, 0.6, 0.7])
    assert "solving 1 clip(s) with 1 job(s); 2 up to date, kept" in lines
    assert sum(line.endswith("(up to date, kept)") for line in lines) == 2
    kept = stamps(out)
    assert all(kept[name] == stamp for name, stamp in before.items())  # not rewritten

    forced = StandIn()
    monkeypatch.setattr(runner, "solve_files", forced)
    solve_library(library, out, robot, jobs=1, replay=False, resume=False)
    assert forced.solved == list(NAMES)  # resume=False (--force): every clip again


def test_rerun_after_an_interrupt_solves_only_what_is_missing(
    library: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    out, robot = tmp_path / "out", ironcub()
    monkeypatch.setattr(runner, "solve_files", StandIn(stop={NAMES[1]}))
    with pytest.raises(KeyboardInterrupt):
        solve_library(library, out, robot, jobs=1, replay=False)
    assert sorted(stamps(out)) == [f"{NAMES[0]}.mcap"]  # written as soon as it was solved
    manifest = json.loads((out / ".motionkit-files.json").read_text())
    assert sorted(manifest["keys"]) == sorted(runner.clip_files([NAMES[0]]))

    again = StandIn()
    monkeypatch.setattr(runner, "solve_files", again)
    assert all(o.solved for o in solve_library(library, out, robot, jobs=1, replay=False))
    assert again.solved == list(NAMES[1:])


def test_a_changed_entry_is_solved_again(
    library: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A clip is kept only under the key it would have now: a changed recipe solves again."""
    out, robot = tmp_path / "out", ironcub()
    monkeypatch.setattr(runner, "solve_files", StandIn())
    solve_library(library, out, robot, jobs=1, replay=False)
    library.write_text(LIBRARY.replace('recipe = "takeoff"', 'recipe = "takeoff"\nrate = 25.0'))
    again = StandIn()
    monkeypatch.setattr(runner, "solve_files", again)
    solve_library(library, out, robot, jobs=1, replay=False)
    assert again.solved == list(NAMES)


def test_summary_says_a_rerun_solves_only_the_failed() -> None:
    outcomes = [
        runner.Outcome(NAMES[0], True, "", {k: figures(NAMES[0])[k] for k in runner.FIGURES}),
        runner.Outcome(NAMES[1], False, "unsolved", {}),
    ]
    text = runner.library_summary(outcomes, 10.0, 2)
    assert "1 of 2 clips solved; airborne 0.5 s in all" in text
    assert text.splitlines()[-1] == (
        f"failed: {NAMES[1]} (the solved clips are kept: the same command again solves only "
        "what is missing)"
    )


def test_summary_line_shows_the_margin_to_the_iteration_limit() -> None:
    metrics = figures(NAMES[0])
    line = runner.summary_line("up", metrics)
    assert line.startswith("up: Solve_Succeeded, 40 iterations (at most 30 of 500 a step), ")
    metrics |= {"retries": 1, "homotopy": [{"iterations": 500}, {"iterations": 120}]}
    assert "(at most 500 of 500 a step, 1 step(s) retried)" in runner.summary_line("up", metrics)
    old = {k: v for k, v in metrics.items() if k not in ("max_iter", "homotopy")}
    assert runner.summary_line("up", old).startswith("up: Solve_Succeeded, 40 iterations, ")


@pytest.mark.slow
def test_real_library_rerun_solves_only_the_failed_clip(tmp_path: Path) -> None:
    """Two small take-offs and one that cannot be solved: the rerun solves the third only
    (the take-offs' files untouched) and fails it again, with the same one-line reason."""
    (tmp_path / "takeoff.toml").write_text((RECIPES / "takeoff.toml").read_text())
    library = tmp_path / "library.toml"
    library.write_text(
        '[[entries]]\nname = "up"\nrecipe = "takeoff"\nscenario = { knots = 12 }\n'
        "grid = [[0.0], [0.0], [0.8, 1.0]]\n"
        '[[entries]]\nname = "moon"\nrecipe = "takeoff"\nscenario = { knots = 10 }\n'
        "solver = { max_iter = 30 }\ntargets = [[0.0, 0.0, 40.0]]\n"
    )
    out, robot = tmp_path / "out", ironcub()
    first = solve_library(library, out, robot, jobs=2, replay=False)
    assert [o.solved for o in first] == [True, True, False]
    before = stamps(out)
    assert sorted(before) == ["up_+0p00_+0p00_+0p80.mcap", "up_+0p00_+0p00_+1p00.mcap"]
    lines: list[str] = []
    again = solve_library(library, out, robot, jobs=2, replay=False, progress=lines.append)
    assert [o.solved for o in again] == [True, True, False]
    assert "solving 1 clip(s) with 2 job(s); 2 up to date, kept" in lines
    assert stamps(out) == before
    assert again[2].text == first[2].text and "\n" not in again[2].text
    assert "IPOPT status" in again[2].text and "retrying" in again[2].text
    for name, height in (("up_+0p00_+0p00_+0p80", 0.8), ("up_+0p00_+0p00_+1p00", 1.0)):
        knots = np.load(out / f"{name}.knots.npz")
        assert knots["com"][-1] == pytest.approx([0.0, 0.0, height], abs=0.01)
