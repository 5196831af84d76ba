"""The fitted thrust model as one file: a NumPy .npz archive (no pickles).

Arrays: w_input (2, 4H), w_hidden (H, 4H), bias (4H), w_out (H), b_out () as step.LSTMThrust
holds them (float32), optionally prior (6 or 13: the LSTM's physical prior, model.py), and
`metadata`: UTF-8 JSON bytes with

    format, version       "motionkit.jet_ident.lstm", 1 (no prior, no dead time) or 2
    dt                    sample interval [s] the model steps by
    delay                 the model's dead time [samples] (version 2)
    normalisation         thrust_mean, thrust_std [N], throttle_mean, throttle_std [%],
                          rate_scale [N/s]
    hidden                LSTM features
    baselines             {"grey_box": {"coeffs": [13]}, "first_order": {"tau", "static"}}
                          fitted in the same run (optional)
    selected              "lstm" or "grey_box": the model of lower validation RMSE (optional)
    anything else         the fit's config, logs, metrics (free-form)

`load_jet(path, "lstm" | "grey_box" | "selected")` gives either model as a step of
`step.thrust_next`.
"""

from __future__ import annotations

import io
import json
import zipfile
import zlib
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import jax.numpy as jnp
import numpy as np

from motionkit.core.errors import JetIdentError
from motionkit.files.inputs import read_bytes
from motionkit.files.outputs import atomic_output
from motionkit.jet_ident.baselines import FirstOrderLag, GreyBox
from motionkit.jet_ident.model import FIRST_ORDER, SECOND_ORDER, Normalisation
from motionkit.jet_ident.step import GreyBoxThrust, LSTMThrust

FORMAT, VERSIONS = "motionkit.jet_ident.lstm", (1, 2)
ARRAYS = ("w_input", "w_hidden", "bias", "w_out", "b_out")
NORMALISATION = ("thrust_mean", "thrust_std", "throttle_mean", "throttle_std", "rate_scale")
JETS = ("lstm", "grey_box", "selected")


def save_model(path: Path, params: LSTMThrust, metadata: dict[str, Any] | None = None) -> None:
    """Write `params` and `metadata` (JSON-serialisable) to `path`, all or nothing.

    The archive's format is the module doc's: the arrays as float32, the metadata as JSON
    with the format, version, dt, delay, hidden and normalisation added.

    Args:
        path: the .npz file to write (its folder is made).
        params: the LSTM model (its prior and dead time included).
        metadata: free-form entries to store beside it, e.g. the baselines and "selected"
            (None: none).

    Returns:
        None.
    """
    norm = {name: float(getattr(params.norm, name)) for name in NORMALISATION}
    header = {
        **(metadata or {}),
        "format": FORMAT,
        "version": 1 if params.prior is None and not params.delay else 2,
        "dt": float(params.dt),
        "delay": params.delay,
        "hidden": params.hidden,
        "normalisation": norm,
    }
    arrays = {name: np.asarray(getattr(params, name), dtype=np.float32) for name in ARRAYS}
    if params.prior is not None:
        arrays["prior"] = np.asarray(params.prior, dtype=np.float32)
    buffer = io.BytesIO()
    np.savez(buffer, metadata=np.frombuffer(json.dumps(header).encode(), np.uint8), **arrays)
    with atomic_output(Path(path)) as stream:
        stream.write(buffer.getvalue())


def load_model(path: Path) -> tuple[LSTMThrust, dict[str, Any]]:
    """The model and metadata in `path`, or JetIdentError saying what is wrong.

    Args:
        path: a .npz file `save_model` wrote.

    Returns:
        The LSTM model (LSTMThrust: arrays, normalisation, dt [s], prior, dead time
        [samples]) and the whole metadata record.

    Raises:
        JetIdentError: a file that cannot be read or is not an .npz archive, missing arrays,
            unreadable or incomplete metadata, another format or version, an array or prior
            of the wrong shape, or a negative delay.
    """
    data = read_bytes(path, JetIdentError, "the thrust model")  # a regular file, never waited on
    try:
        with np.load(io.BytesIO(data), allow_pickle=False) as archive:
            contents = {name: archive[name] for name in archive.files}
    except (OSError, ValueError, EOFError, zipfile.BadZipFile, zlib.error) as exc:
        raise JetIdentError(f"{path}: not a motionkit thrust model (.npz) ({exc})") from None
    missing = [name for name in (*ARRAYS, "metadata") if name not in contents]
    if missing:
        raise JetIdentError(f"{path}: not a motionkit thrust model; missing {', '.join(missing)}")
    try:
        metadata = json.loads(contents["metadata"].tobytes().decode())
        norm = Normalisation(
            **{name: float(metadata["normalisation"][name]) for name in NORMALISATION}
        )
        dt = float(metadata["dt"])
        delay = int(metadata.get("delay", 0))
    except (ValueError, KeyError, TypeError) as exc:
        raise JetIdentError(f"{path}: metadata is unreadable or incomplete ({exc})") from exc
    if metadata.get("format") != FORMAT or metadata.get("version") not in VERSIONS:
        raise JetIdentError(
            f"{path}: format {metadata.get('format')!r} version {metadata.get('version')!r}; "
            f"expected {FORMAT!r} version {' or '.join(map(str, VERSIONS))}"
        )
    w = {name: jnp.asarray(contents[name]) for name in ARRAYS}
    hidden = w["w_hidden"].shape[0]
    shapes = {"w_input": (2, 4 * hidden), "w_hidden": (hidden, 4 * hidden), "bias": (4 * hidden,)}
    shapes |= {"w_out": (hidden,), "b_out": ()}
    for name, shape in shapes.items():
        if w[name].shape != shape:
            raise JetIdentError(f"{path}: {name} has shape {w[name].shape}, expected {shape}")
    prior = contents.get("prior")
    if prior is not None and prior.shape not in ((FIRST_ORDER,), (SECOND_ORDER,)):
        raise JetIdentError(
            f"{path}: prior has shape {prior.shape}, expected ({FIRST_ORDER},) or ({SECOND_ORDER},)"
        )
    if delay < 0:
        raise JetIdentError(f"{path}: delay {delay}: expected 0 or more samples")
    prior = None if prior is None else jnp.asarray(prior)
    return LSTMThrust(**w, norm=norm, dt=dt, prior=prior, delay=delay), metadata


def load_jet(path: Path, jet: str = "lstm") -> LSTMThrust | GreyBoxThrust:
    """The step of one model in `path`, as the `params` of `thrust_next`.

    The LSTM, the grey box fitted beside it, or the one `selected` on validation (the LSTM
    where the file does not say).

    Args:
        path: a .npz file `save_model` wrote.
        jet: "lstm", "grey_box" or "selected".

    Returns:
        The LSTMThrust, or a GreyBoxThrust (its 13 coefficients, the LSTM's dt [s]).

    Raises:
        JetIdentError: an unknown `jet`, a file `load_model` refuses, unreadable baselines,
            or a grey box asked of a file that holds none.
    """
    if jet not in JETS:
        raise JetIdentError(f"jet {jet!r}: expected one of {', '.join(JETS)}")
    params, metadata = load_model(path)
    if jet == "selected":
        jet = metadata.get("selected", "lstm")
    if jet == "lstm":
        return params
    grey = baselines_from_metadata(metadata).get("grey-box 2nd order")
    if not isinstance(grey, GreyBox):
        raise JetIdentError(f"{path}: holds no grey box (fitted by an older motionkit)")
    return GreyBoxThrust(jnp.asarray(grey.coeffs, jnp.float32), params.dt)


def selected(metrics: Mapping[str, Any]) -> str:
    """'lstm' or 'grey_box': the lower validation RMSE of the two (the LSTM on a tie)."""
    return "lstm" if metrics["LSTM"].rmse <= metrics["grey-box 2nd order"].rmse else "grey_box"


def baselines_metadata(grey_box: GreyBox, first_order: FirstOrderLag) -> dict[str, Any]:
    return {
        "grey_box": {"coeffs": list(grey_box.coeffs)},
        "first_order": {"tau": first_order.tau, "static": list(first_order.static)},
    }


def baselines_from_metadata(metadata: dict[str, Any]) -> dict[str, GreyBox | FirstOrderLag]:
    """The baselines stored beside the LSTM ({} when there are none)."""
    stored = metadata.get("baselines") or {}
    out: dict[str, GreyBox | FirstOrderLag] = {}
    try:
        if "grey_box" in stored:
            out["grey-box 2nd order"] = GreyBox(
                tuple(float(c) for c in stored["grey_box"]["coeffs"])
            )
        if "first_order" in stored:
            lag = stored["first_order"]
            static = tuple(float(a) for a in lag["static"])
            out["first-order lag"] = FirstOrderLag(float(lag["tau"]), static)  # type: ignore[arg-type]
    except (KeyError, TypeError, ValueError) as exc:
        raise JetIdentError(f"the model's baselines are unreadable ({exc})") from exc
    return out
