"""Export: one .npz file round trip, and clear errors for files that are not models."""

import json
from pathlib import Path

import jax
import numpy as np
import pytest

from motionkit.core.errors import JetIdentError
from motionkit.jet_ident.baselines import FirstOrderLag, GreyBox
from motionkit.jet_ident.export import (
    baselines_from_metadata,
    baselines_metadata,
    load_jet,
    load_model,
    save_model,
    selected,
)
from motionkit.jet_ident.model import Normalisation, init_variables
from motionkit.jet_ident.p250 import P250_COEFFS
from motionkit.jet_ident.step import GreyBoxThrust, LSTMThrust


def _params(prior: np.ndarray | None = None) -> LSTMThrust:
    norm = Normalisation(101.5, 61.25, 44.0, 29.5, 61.25)
    return LSTMThrust.from_variables(init_variables(5, 0, prior), norm, 0.01)


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
    assert back.prior is None and metadata["version"] == 1


def test_prior_and_grey_box_round_trip(tmp_path: Path) -> None:
    params = _params(P250_COEFFS)
    grey = GreyBox(tuple(float(c) for c in P250_COEFFS * 1.01))
    lag = FirstOrderLag(0.7, (12.0, 1.5, 0.004))
    meta = {"baselines": baselines_metadata(grey, lag), "selected": "grey_box"}
    save_model(tmp_path / "m.npz", params.replace(delay=4), meta)
    back, metadata = load_model(tmp_path / "m.npz")
    assert metadata["version"] == 2 and back.delay == 4
    np.testing.assert_allclose(np.asarray(back.prior), P250_COEFFS, rtol=1e-6)
    assert isinstance(load_jet(tmp_path / "m.npz"), LSTMThrust)
    jet = load_jet(tmp_path / "m.npz", "selected")
    assert isinstance(jet, GreyBoxThrust) and jet.dt == 0.01
    np.testing.assert_allclose(np.asarray(jet.coeffs), grey.coeffs, rtol=1e-6)
    save_model(tmp_path / "bare.npz", params)  # no baselines, no choice: the LSTM
    assert isinstance(load_jet(tmp_path / "bare.npz", "selected"), LSTMThrust)
    with pytest.raises(JetIdentError, match="holds no grey box"):
        load_jet(tmp_path / "bare.npz", "grey_box")
    with pytest.raises(JetIdentError, match="jet 'best'"):
        load_jet(tmp_path / "m.npz", "best")


def test_selected_is_the_lower_validation_rmse() -> None:
    class M:
        def __init__(self, rmse: float) -> None:
            self.rmse = rmse

    assert selected({"LSTM": M(2.0), "grey-box 2nd order": M(2.5)}) == "lstm"
    assert selected({"LSTM": M(2.0), "grey-box 2nd order": M(2.0)}) == "lstm"
    assert selected({"LSTM": M(3.0), "grey-box 2nd order": M(2.5)}) == "grey_box"


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
    np.savez(tmp_path / "prior.npz", **contents, prior=np.zeros(7, np.float32))
    with pytest.raises(JetIdentError, match=r"prior has shape \(7,\)"):
        load_model(tmp_path / "prior.npz")
