"""`motionkit train --help` and its refusals (no training: those are test_training's)."""

from pathlib import Path

import pytest

from motionkit import recipes
from motionkit.cli import main


def test_help_explains_the_config_and_outputs(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit):
        main(["train", "--help"])
    text = capsys.readouterr().out
    for needle in ("[priors.NAME]", "--priors", "checkpoint.msgpack", "rollouts/iter_N.mcap"):
        assert needle in text


def test_refusals(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    recipe = recipes.find("train", "tiny_cpu")
    assert main(["train", "--out", str(tmp_path)]) == 2
    assert "needs --config" in capsys.readouterr().err
    assert main(["train", "--config", str(recipe), "--out", str(tmp_path), "--priors", "walk"]) == 2
    assert "[priors.*] tables for none" in capsys.readouterr().err
    assert main(["train", "--config", str(recipe), "--out", str(tmp_path), "--resume"]) == 2
    assert "nothing to resume" in capsys.readouterr().err
    assert main(["train", "ablation", "--config", str(recipe), "--out", str(tmp_path)]) == 2
    assert "needs [priors.walk] and [priors.flight]" in capsys.readouterr().err
    assert not (tmp_path / "train.csv").exists()


def test_importing_the_trainer_prints_nothing() -> None:
    """MJX's import prints a notice per missing warp package; the trainer imports it quietly."""
    import subprocess
    import sys

    code = "import motionkit.train.env, motionkit.train.learner"
    run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, run.stderr
    assert run.stdout == ""
