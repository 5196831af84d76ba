"""`jet-ident simulate|fit|eval` on tiny settings, through add_commands on a local parser."""

import argparse
import json
from pathlib import Path

import pytest

from motionkit.core.errors import JetIdentError
from motionkit.jet_ident.command import add_commands
from motionkit.jet_ident.export import load_model

TINY = """
[bench]
duration_s = 80.0
[model]
hidden = 8
[train]
warmup = 10
window = 60
batch = 8
max_steps = 40
eval_every = 20
"""


def _run(argv: list[str]) -> int:
    parser = argparse.ArgumentParser(prog="motionkit")
    add_commands(parser.add_subparsers(dest="command", required=True))
    args = parser.parse_args(argv)
    return args.handler(args) or 0


def test_help_documents_columns_and_outputs(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit):
        _run(["jet-ident", "fit", "--help"])
    text = capsys.readouterr().out
    assert "time_s, throttle_pct, thrust_n" in text and "model.npz" in text


def test_simulate_fit_eval(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    recipe = tmp_path / "tiny.toml"
    recipe.write_text(TINY)
    for seed in (1, 2):
        assert _run(["jet-ident", "simulate", "--config", str(recipe), "--seed", str(seed),
                     "--out", str(tmp_path / f"p{seed}.csv")]) == 0  # fmt: skip
    assert "8000 samples at 100 Hz" in capsys.readouterr().out

    out = tmp_path / "fit"
    assert _run(["jet-ident", "fit", str(tmp_path / "p1.csv"), "--config", str(recipe),
                 "--out", str(out)]) == 0  # fmt: skip
    printed = capsys.readouterr().out
    assert "noise floor" in printed and "grey-box 2nd order" in printed
    assert {"model.npz", "config.toml", "report.json", "report.txt", "history.csv"} <= {
        p.name for p in out.iterdir()
    }
    report = json.loads((out / "report.json").read_text())
    assert set(report["metrics"]) == {"LSTM", "grey-box 2nd order", "first-order lag"}
    params, metadata = load_model(out / "model.npz")
    assert params.hidden == 8 and metadata["warmup"] == 10

    assert _run(["jet-ident", "eval", str(out / "model.npz"), str(tmp_path / "p2.csv"),
                 "--json"]) == 0  # fmt: skip
    scores = json.loads(capsys.readouterr().out)
    assert scores["warmup"] == 10 and scores["metrics"]["LSTM"]["samples"] == 8000 - 10
    assert scores["noise_floor"]["rmse"] == pytest.approx(1.5, rel=0.1)


def test_bad_inputs_raise_and_write_nothing(tmp_path: Path) -> None:
    bad = tmp_path / "bad.csv"
    bad.write_text("time_s,throttle_pct,thrust_n\n0,0,15\n0.01,120,15\n")
    with pytest.raises(JetIdentError, match="line 3: throttle_pct 120"):
        _run(["jet-ident", "fit", str(bad), "--out", str(tmp_path / "fit")])
    assert not (tmp_path / "fit").exists()
    with pytest.raises(JetIdentError, match="not a motionkit thrust model"):
        _run(["jet-ident", "eval", str(bad), str(bad)])
    with pytest.raises(JetIdentError, match="--duration"):
        _run(["jet-ident", "simulate", "--duration", "1", "--out", str(tmp_path / "x.csv")])
    assert not (tmp_path / "x.csv").exists()
