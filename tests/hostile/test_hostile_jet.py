"""Hostile files through `motionkit jet-ident eval`: a FIFO bench log is refused, not waited
on, and a model file that is truncated or not an npz is refused with one line naming it."""

from __future__ import annotations

import os
from pathlib import Path

import pytest
from hostile_support import no_hang, refused

pytest.importorskip("jax")

from motionkit.jet_ident.export import save_model
from motionkit.jet_ident.model import Normalisation, init_variables
from motionkit.jet_ident.step import LSTMThrust

LOG = "time_s,throttle_pct,thrust_n\n" + "".join(
    f"{0.01 * i:.2f},{min(i, 60)}.0,{15 + i * 0.5:.1f}\n" for i in range(80)
)


@pytest.fixture
def model(tmp_path: Path) -> Path:
    norm = Normalisation(101.5, 61.25, 44.0, 29.5, 61.25)
    path = tmp_path / "model.npz"
    save_model(path, LSTMThrust.from_variables(init_variables(5, 0, None), norm, 0.01))
    return path


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="no FIFOs on this system")
def test_a_fifo_log_is_refused_not_waited_on(model: Path, tmp_path: Path, capsys) -> None:
    fifo = tmp_path / "log.csv"
    os.mkfifo(fifo)
    with no_hang():
        refused(["jet-ident", "eval", str(model), str(fifo)], capsys, 2, rf"{fifo}: .*a FIFO")


@pytest.mark.parametrize("damage", ["truncated", "not an npz"])
def test_a_damaged_model_is_refused(damage: str, model: Path, tmp_path: Path, capsys) -> None:
    log = tmp_path / "log.csv"
    log.write_text(LOG)
    data = model.read_bytes()
    model.write_bytes(data[: len(data) // 2] if damage == "truncated" else b"hello" * 40)
    argv = ["jet-ident", "eval", str(model), str(log)]
    refused(argv, capsys, 2, rf"{model}: not a motionkit thrust model \(\.npz\)")
