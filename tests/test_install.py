"""An installed motionkit (not the checkout) works from an empty folder: its recipes, its sample
and the pipeline's first stage, offline."""

import os
import subprocess
import sys
import sysconfig
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def installed(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A fresh virtual environment with motionkit installed from the checkout (a wheel build,
    so only what the package ships); its dependencies come from this environment."""
    venv = tmp_path_factory.mktemp("venv")
    subprocess.run([sys.executable, "-m", "venv", str(venv)], check=True)
    pip = [str(venv / "bin" / "python"), "-m", "pip", "install", "--quiet", "--no-deps"]
    subprocess.run([*pip, str(REPO)], check=True, cwd=tmp_path_factory.mktemp("build"))
    # then this environment's packages after its own (their .pth files too: pin's cmeel paths)
    site = next(venv.glob("lib/python*/site-packages"))
    parent = sysconfig.get_paths()["purelib"]
    (site / "deps.pth").write_text(f"import site; site.addsitedir({parent!r})\n")
    return venv / "bin"


def run(bin: Path, cwd: Path, *args: str) -> subprocess.CompletedProcess:
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    env["MOTIONKIT_CACHE"] = str(cwd / "cache")
    return subprocess.run(
        [str(bin / args[0]), *args[1:]], cwd=cwd, env=env, capture_output=True, text=True
    )


@pytest.mark.slow
def test_installed_package_runs_from_an_empty_folder(installed: Path, tmp_path: Path) -> None:
    where = run(installed, tmp_path, "python", "-c", "import motionkit; print(motionkit.__file__)")
    assert where.returncode == 0, where.stderr
    assert str(REPO) not in where.stdout and "site-packages" in where.stdout
    listing = run(installed, tmp_path, "motionkit", "recipes")
    assert listing.returncode == 0, listing.stderr
    assert "walk_to_fly" in listing.stdout and "sample_walks" in listing.stdout
    assert str(REPO) not in listing.stdout  # the installed copies
    result = run(installed, tmp_path, "motionkit", "pipeline", "--until", "retarget")
    assert result.returncode == 0, result.stdout[-2000:] + result.stderr[-2000:]
    clips = sorted(p.name for p in (tmp_path / "runs" / "pipeline" / "walk").glob("*.mcap"))
    assert clips == ["02_01.mcap", "11_01.mcap", "35_01.mcap"]
    assert not list((tmp_path / "cache").rglob("*.amc"))  # nothing was downloaded


@pytest.mark.slow
def test_the_installed_package_plays_its_shipped_policy(installed: Path, tmp_path: Path) -> None:
    """A newcomer's first play, from an empty folder: the shipped policy came with the wheel."""
    result = run(installed, tmp_path, "motionkit", "play", "--waypoints", "1.5,0,0.6 3,1,0.6",
                 "--out", "plays")  # fmt: skip
    assert result.returncode == 0, result.stdout[-2000:] + result.stderr[-2000:]
    assert "site-packages" in result.stdout and "policies/walk_fly" in result.stdout
    assert result.stdout.count(": reached at ") == 2 and "x real time" in result.stdout
    assert (tmp_path / "plays" / "play.mcap").stat().st_size > 0
