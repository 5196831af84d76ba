"""A command whose extra is missing says which extra to install, with no traceback."""

import sys
from pathlib import Path

import pytest

from motionkit.cli import main
from motionkit.core.errors import TrajoptError
from motionkit.core.extras import EXTRAS, require


def test_require_names_the_missing_module_and_the_extra(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setitem(sys.modules, "casadi", None)  # an import of casadi now fails
    with pytest.raises(TrajoptError) as caught:
        require("trajopt", "trajectory optimisation", TrajoptError)
    assert str(caught.value) == (
        "trajectory optimisation needs the [trajopt] extra (casadi is missing): "
        "pip install 'motionkit[trajopt]'"
    )
    require("trajopt", "trajectory optimisation", TrajoptError, ("numpy",))  # only these
    assert set(EXTRAS) == {"ik", "trajopt", "train", "viewer", "cluster"}


def test_trajopt_without_its_extra_exits_with_one_line(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    monkeypatch.setitem(sys.modules, "casadi", None)
    code = main(["trajopt", "--scenario", "takeoff", "--out", str(tmp_path / "out")])
    err = capsys.readouterr().err
    assert code == 2 and "pip install 'motionkit[trajopt]'" in err
    assert "Traceback" not in err and not (tmp_path / "out").exists()


def test_the_train_extra_is_checked_without_a_word_about_absent_backends() -> None:
    """MJX prints "Failed to import warp" on import where warp is absent: the check (every
    train, play and pipeline command makes it) imports it in a fresh interpreter silently."""
    import subprocess

    pytest.importorskip("mujoco.mjx")
    code = (
        "from motionkit.core.errors import TrainError; from motionkit.core.extras import require; "
        "require('train', 'training', TrainError); import mujoco.mjx; print('ok')"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    assert done.stdout == "ok\n" and "warp" not in done.stderr
