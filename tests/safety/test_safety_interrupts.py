"""Interrupts end cleanly: SIGTERM (to the command) and Ctrl-C (SIGINT to its process group) of
`motionkit retarget --jobs 2` and of the pipeline end the workers too, leave no temporary file,
only complete clips, one line on stderr and the status 143 / 130; a pipeline stage that is
interrupted keeps its previous output."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path

import pytest
from safety_support import environment, snapshot, temporaries, walk_bvh

from motionkit.dataset import read
from motionkit.dataset.validate import validate_clip
from motionkit.robot import ironcub

pytest.importorskip("placo")
pytest.importorskip("psutil")

CLIPS, FRAMES = 6, 600  # about 0.5 s a clip: a second of work queued after the first


def start(argv: list[str], cwd: Path) -> subprocess.Popen[str]:
    """`python -m motionkit.cli ARGV` in a session of its own (its process group is its pid)."""
    return subprocess.Popen(
        [sys.executable, "-m", "motionkit.cli", *argv],
        cwd=cwd,
        env=environment(),
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,
        preexec_fn=_ctrl_c_as_in_a_terminal,
    )


def _ctrl_c_as_in_a_terminal() -> None:
    """SIGINT at its default in the child, as in a terminal: a test run started in the
    background (`cmd &`) passes it on ignored, and Python then never raises KeyboardInterrupt."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def wait_for(
    condition: Callable[[], bool], process: subprocess.Popen[str], seconds: float = 240.0
) -> None:
    end = time.monotonic() + seconds
    while not condition():
        assert process.poll() is None, f"ended early: {process.stderr.read()}"
        assert time.monotonic() < end, "timed out"
        time.sleep(0.05)


def interrupt(process: subprocess.Popen[str], signum: int) -> tuple[int, str]:
    """SIGTERM to the process, or SIGINT to its group (a terminal's Ctrl-C); status, stderr."""
    if signum == signal.SIGINT:
        os.killpg(process.pid, signum)
    else:
        process.send_signal(signum)
    _, err = process.communicate(timeout=60)
    return process.returncode, err


def survivors(group: int) -> list[int]:
    """Processes of the group still alive 3 s after the command ended (zombies count as gone)."""
    import psutil

    time.sleep(3.0)
    alive = []
    for process in psutil.process_iter(["status"]):
        try:
            if os.getpgid(process.pid) == group and process.info["status"] != "zombie":
                alive.append(process.pid)
        except (ProcessLookupError, psutil.Error):
            pass
    return alive


def check_clips(folder: Path, expected: int | None = None) -> list[Path]:
    """Every clip in `folder` reads and validates; no temporary is left."""
    assert temporaries(folder) == []
    clips = sorted(folder.glob("*.mcap"))
    robot = ironcub()
    for clip in clips:
        assert read(clip).frames > 2
        failed = [c for c in validate_clip(clip, robot) if not c.ok and not c.warning]
        assert not failed, (clip, failed)
    return clips


@pytest.mark.parametrize(("signum", "status", "line"), [
    (signal.SIGTERM, 143, "motionkit: terminated"),
    (signal.SIGINT, 130, "motionkit: interrupted"),
])  # fmt: skip
def test_retarget_jobs_2_ends_with_its_workers(
    tmp_path: Path, signum: int, status: int, line: str
) -> None:
    for k in range(CLIPS):
        walk_bvh(tmp_path / "in" / f"walk{k}.bvh", FRAMES)
    out = tmp_path / "out"
    process = start(["retarget", "in", "--out", "out", "--jobs", "2"], tmp_path)
    wait_for(lambda: any(out.glob("*.mcap")), process)
    code, err = interrupt(process, signum)
    assert (code, err.splitlines()) == (status, [line])
    assert survivors(process.pid) == []
    clips = check_clips(out)
    assert 1 <= len(clips) < CLIPS  # the queued clips were cancelled, not run
    assert not (out / "retarget_summary.json").exists()


def test_interrupted_pipeline_stage_keeps_the_previous_output(tmp_path: Path) -> None:
    from test_safety_outputs import pipeline_recipe

    mocap = tmp_path / "mocap"
    walk_bvh(mocap / "walk.bvh", 12)
    argv = ["pipeline", "--config", str(pipeline_recipe(tmp_path)), "--out", "out",
            "--mocap-dir", "mocap", "--until", "retarget"]  # fmt: skip
    first = start(argv, tmp_path)
    assert first.wait(timeout=300) == 0, first.stderr.read()
    out = tmp_path / "out"
    before = snapshot(out)

    for k in range(CLIPS):  # a longer rerun, stopped while it retargets
        walk_bvh(mocap / f"more{k}.bvh", FRAMES)
    process = start([*argv, "--force"], tmp_path)
    staging = out / ".staging" / "walk"
    wait_for(lambda: any(staging.glob("*.mcap")), process)
    code, err = interrupt(process, signal.SIGTERM)
    assert (code, err.splitlines()) == (143, ["motionkit: terminated"])
    assert survivors(process.pid) == []
    assert snapshot(out) == before  # the staging folder is gone, the previous walk/ untouched
    assert [clip.name for clip in check_clips(out / "walk")] == ["walk.mcap"]


@pytest.mark.parametrize("signum", [signal.SIGTERM, signal.SIGINT])
def test_trajopt_ends_during_an_ipopt_solve(signum: int, tmp_path: Path) -> None:
    """CasADi turns the interrupt its signal handler raises inside IPOPT into a warning: the
    command still ends within seconds with 143 / 130, one line and no output."""
    pytest.importorskip("casadi")
    out = tmp_path / "flight"
    process = subprocess.Popen(
        [sys.executable, "-m", "motionkit.cli", "trajopt", "--scenario", "takeoff", "--out",
         str(out)],
        cwd=tmp_path,
        env=environment() | {"MOTIONKIT_TRAJOPT_COMPILE": "-O0"},
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,
        preexec_fn=_ctrl_c_as_in_a_terminal,
    )  # fmt: skip
    for line in process.stdout:  # IPOPT's iteration table: the solve is under way
        if line.startswith("iter "):
            break
    else:
        pytest.fail(f"no IPOPT iterations: {process.stderr.read()}")
    sent = time.monotonic()
    code, err = interrupt(process, signum)
    assert time.monotonic() - sent < 10.0
    assert code == 128 + signum, err
    assert err.strip().splitlines()[-1] == (
        "motionkit: terminated" if signum == signal.SIGTERM else "motionkit: interrupted"
    )
    assert "Traceback" not in err and not out.exists()
