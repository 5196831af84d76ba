"""Helpers of the safety tests: small mocap clips, a folder nobody may write, file snapshots."""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

import pytest
from mocap_synth import arms_down, mini_bvh

REPO = Path(__file__).resolve().parents[2]


def walk_bvh(path: Path, frames: int = 40) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(mini_bvh(arms_down(frames)))
    return path


def snapshot(folder: Path) -> dict[str, bytes]:
    """Every file below `folder` (hidden ones included) and its bytes."""
    return {
        str(p.relative_to(folder)): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()
    }


def temporaries(folder: Path) -> list[Path]:
    return sorted(p for p in folder.rglob("*") if p.name.endswith(".tmp"))


def read_only_folder(tmp_path: Path) -> Path:
    """An existing folder this process cannot write: a mode-555 one, or /sys for root (whom
    file modes do not stop; /sys is mounted read-only)."""
    if os.geteuid() != 0:
        folder = tmp_path / "locked"
        folder.mkdir()
        folder.chmod(0o555)
        return folder
    try:
        tempfile.TemporaryFile(dir="/sys").close()
    except OSError:
        return Path("/sys")
    pytest.skip("no read-only folder for root on this machine")


def environment() -> dict[str, str]:
    """This process's environment (MOTIONKIT_CACHE included) with motionkit importable."""
    return os.environ | {"PYTHONPATH": str(REPO), "OMP_NUM_THREADS": "1"}
