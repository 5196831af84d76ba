"""Export: one .npz file round trip, and clear errors for files that are not models."""

import json
from pathlib import Path

import jax
import numpy as np
import pytest

from motionkit.errors import JetIdentError
from motionkit.jet_ident.baselines import FirstOrderLag, GreyBox
from motionkit.jet_ident.export import (
    baselines_from_metadata,
    baselines_metadata,
    load_model,
    save_model,
)
from motionkit.jet_ident.model import Normalisation, init_variables
from motionkit.jet_ident.step import LSTMThrust


def _params() -> LSTMThrust:
    norm = Normalisation(101.5, 61.25, 44.0, 29.5, 61.25)
    return LSTMThrust.from_variables(init_variables(5, 0), norm, 0.01)


def test_round_trip(tmp_path: Path) -> None:
    params = _params()
    grey = GreyBox(tuple(float(i) for i in range(13)))
    lag = FirstOrderLag(0.7, (12.0, 1.5, 0.004))
    meta = {"baselines": baselines_metadata(grey, lag), "note": "x"}
    save_model(tmp_path / "m.npz", params, meta)
    back, metadata = load_model(tmp_path / "m.npz")
    assert [p.name for p in tmp_path.iterdir()] == ["m.npz"]
    for a, b in zip(jax.tree.leaves(params), jax.tree.leaves(back), strict=True):
        np.testing.assert_allclose(np.asarray(b), np.asarray(a), rtol=1e-7)
    assert back.norm == params.norm and back.dt == 0.01 and back.hidden == 5
    assert metadata["note"] == "x" and metadata["format"] == "motionkit.jet_ident.lstm"
    assert metadata["normalisation"]["thrust_std"] == 61.25
    baselines = baselines_from_metadata(metadata)
    assert baselines["grey-box 2nd order"] == grey
    assert baselines["first-order lag"] == lag


def test_not_a_model(tmp_path: Path) -> None:
    (tmp_path / "x.npz").write_text("hello")
    with pytest.raises(JetIdentError, match="not a motionkit thrust model"):
        load_model(tmp_path / "x.npz")
    np.savez(tmp_path / "y.npz", a=np.zeros(3))
    with pytest.raises(JetIdentError, match="missing w_input"):
        load_model(tmp_path / "y.npz")
    with pytest.raises(JetIdentError, match="cannot read"):
        load_model(tmp_path / "absent.npz")


def test_wrong_shape_and_wrong_format(tmp_path: Path) -> None:
    save_model(tmp_path / "m.npz", _params())
    with np.load(tmp_path / "m.npz") as archive:
        contents = dict(archive)
    bad = {**contents, "bias": np.zeros(3, np.float32)}
    np.savez(tmp_path / "bad.npz", **bad)
    with pytest.raises(JetIdentError, match="bias has shape"):
        load_model(tmp_path / "bad.npz")
    header = json.loads(contents["metadata"].tobytes())
    header["format"] = "other"
    other = {**contents, "metadata": np.frombuffer(json.dumps(header).encode(), np.uint8)}
    np.savez(tmp_path / "other.npz", **other)
    with pytest.raises(JetIdentError, match="format 'other'"):
        load_model(tmp_path / "other.npz")
