"""The library never prints: each stage's Python entry point writes nothing to stdout or stderr
(its worker processes included) unless given a `progress` callback, which then receives the
lines the command prints."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import pytest
from mocap_synth import arms_down, mini_bvh

from motionkit.jet_ident.config import BenchConfig, JetIdentConfig, ModelConfig, TrainConfig
from motionkit.robot import ironcub

TINY_JET = JetIdentConfig(
    bench=BenchConfig(duration_s=60.0),
    model=ModelConfig(hidden=8, priors=("none",)),
    train=TrainConfig(warmup=10, window=60, long_window=0, batch=8, max_steps=20, eval_every=10),
)


def nothing_shown(capfd: pytest.CaptureFixture[str]) -> None:
    out, err = capfd.readouterr()
    assert (out, err) == ("", ""), (out, err)


def walks(folder: Path) -> Path:
    """A good walk and a file that is no BVH: the failure lines are tried too."""
    folder.mkdir()
    (folder / "walk.bvh").write_text(mini_bvh(arms_down(20)))
    (folder / "bad.bvh").write_text("HIERARCHY\nROOT Hips\n{\n")
    return folder


def test_retarget_prints_nothing(tmp_path: Path, capfd: pytest.CaptureFixture[str]) -> None:
    pytest.importorskip("placo")
    from motionkit.retarget import RetargetConfig, resolve_inputs, run_retarget

    robot = ironcub()
    config = replace(RetargetConfig(), balance=replace(RetargetConfig().balance, passes=0))
    clips = resolve_inputs([str(walks(tmp_path / "in"))])
    capfd.readouterr()
    results = run_retarget(clips, tmp_path / "out", config, 1, robot)
    assert [r.output is None for r in results] == [True, False]
    nothing_shown(capfd)

    lines: list[str] = []
    run_retarget(clips, tmp_path / "out", config, 1, robot, resume=True, progress=lines.append)
    nothing_shown(capfd)
    assert lines[0].startswith("retargeting 2 clip(s) into ")
    assert "[1/2] walk: up to date, kept -> " in lines[1] and "[2/2] bad: failed: " in lines[2]
    assert lines[-1] == "1 of 2 clip(s) failed; nothing written for them"


def test_jet_ident_fit_prints_nothing(tmp_path: Path, capfd: pytest.CaptureFixture[str]) -> None:
    pytest.importorskip("optax")
    from motionkit.jet_ident import fit_logs, write_log
    from motionkit.jet_ident.synthetic import synthetic_run

    log = tmp_path / "p250_1.csv"
    write_log(log, synthetic_run(TINY_JET.bench, 1).log)
    capfd.readouterr()
    report = fit_logs([log], tmp_path / "fit", TINY_JET)
    assert (tmp_path / "fit" / "model.npz").is_file() and report["selected"]
    nothing_shown(capfd)

    lines: list[str] = []
    fit_logs([log], tmp_path / "fit", TINY_JET, progress=lines.append)
    nothing_shown(capfd)
    assert lines[0] == "1 log(s): p250_1 (60 s)" and "validation MAE" in lines[2]
    assert lines[-1].startswith("wrote ") and lines[-1].endswith("report.txt, history.csv")


def test_pipeline_prints_nothing(tmp_path: Path, capfd: pytest.CaptureFixture[str]) -> None:
    pytest.importorskip("placo")
    from motionkit.pipeline import PipelineConfig, run_pipeline

    mocap = tmp_path / "mocap"
    mocap.mkdir()
    (mocap / "walk.bvh").write_text(mini_bvh(arms_down(20)))
    (tmp_path / "retarget.toml").write_text('kind = "walk"\n[balance]\npasses = 0\n')
    recipe = tmp_path / "pipeline.toml"
    recipe.write_text(  # the stages after retarget are not run
        '[retarget]\nrecipe = "retarget.toml"\njobs = 1\n[trajopt]\nrecipes = ["takeoff"]\n'
        '[jet_ident]\nrecipe = "p250"\n[train]\nrecipe = "tiny_cpu"\nfull_recipe = "tiny_cpu"\n'
    )
    config, out = PipelineConfig.from_toml(recipe), tmp_path / "out"
    capfd.readouterr()
    outcomes = run_pipeline(config, out, ironcub(), mocap_dir=mocap, until="retarget")
    assert [o.status for o in outcomes] == ["ran"]
    nothing_shown(capfd)

    lines: list[str] = []
    run_pipeline(config, out, ironcub(), mocap_dir=mocap, until="retarget", progress=lines.append)
    nothing_shown(capfd)
    assert lines[0] == "\n=== [1/1] retarget" and lines[1].startswith("cached (key ")
    assert lines[-1].startswith("total ")


@pytest.mark.slow
def test_trajopt_prints_nothing(tmp_path: Path, capfd: pytest.CaptureFixture[str]) -> None:
    """A small take-off in a worker process (quiet IPOPT), then kept by --resume."""
    pytest.importorskip("casadi")
    from motionkit import recipes
    from motionkit.trajopt import TrajoptConfig, solve_grid

    config = TrajoptConfig.from_toml(recipes.find("trajopt", "takeoff")).with_scenario(knots=12)
    config = replace(config, solver=replace(config.solver, print_level=0))
    robot, out = ironcub(), tmp_path / "out"
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("MOTIONKIT_TRAJOPT_COMPILE", "-O0")  # seconds, not minutes
        capfd.readouterr()
        outcomes = solve_grid(config, [(0.0, 0.0, 1.0)], out, robot, 1, replay=False)
        assert [o.solved for o in outcomes] == [True]
        nothing_shown(capfd)

        lines: list[str] = []
        solve_grid(config, [(0.0, 0.0, 1.0)], out, robot, 1, False, resume=True,
                   progress=lines.append)  # fmt: skip
    nothing_shown(capfd)
    assert lines[0].endswith("(up to date, kept)")
    assert lines[1] == "solving 0 clip(s) with 1 job(s); 1 up to date, kept"
