"""The notebooks: one per stage, saved without outputs, and each one runs from a clean kernel on
its smallest settings (MOTIONKIT_NB_SMALL=1), draws at least one figure and ends with a checks
cell whose key results (a `RESULT {json}` line) are checked again here."""

from __future__ import annotations

import json
import os
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest

ROOT = Path(__file__).resolve().parents[2]
FOLDER = ROOT / "notebooks"
STAGES = ("01_robot", "02_retarget", "03_trajopt", "04_jet_ident", "05_dataset", "06_train")
CELL_TIMEOUT = 900  # s; the train notebook's MJX compile is one cell (1-4 min on a 2-core CPU)

# What each notebook needs beyond the base install (skipped without it), and what its RESULT
# line must say.
NEEDS: dict[str, tuple[str, ...]] = {
    "01_robot": ("matplotlib", "mujoco"),
    "02_retarget": ("matplotlib", "placo"),
    "03_trajopt": ("matplotlib", "casadi", "adam"),
    "04_jet_ident": ("matplotlib", "jax", "flax", "optax"),
    "05_dataset": ("matplotlib",),
    "06_train": ("matplotlib", "jax", "flax", "optax", "mujoco.mjx"),
}
EXPECT: dict[str, Callable[[dict[str, Any]], bool]] = {
    "01_robot": lambda r: (
        r["joints"] == 23
        and r["jets"] == 4
        and abs(r["mass_kg"] - 44.7263) < 1e-3
        and r["com_over_support"]
        and r["stand_sag_m"] < 0.03
    ),
    "02_retarget": lambda r: (
        r["frames"] > 0
        and r["foot_slide_p95_m_s"] <= 0.01
        and r["penetration_max_m"] <= 0.002
        and r["limit_violations"] == 0
        and r["feet_error_mean_m"] <= 0.03
        and r["valid_clip"]
    ),
    "03_trajopt": lambda r: (
        r["passed"] and r["target_error_m"] <= 0.01 and r["lift_off"] and r["clip_frames"] > 0
    ),
    "04_jet_ident": lambda r: (
        r["lstm_mae_n"] < 3.0
        and r["lstm_rmse_n"] < 5.0
        and r["lstm_mae_n"] < r["first_order_mae_n"]
        and r["model_round_trip"]
    ),
    "05_dataset": lambda r: r["round_trip_equal"] and r["valid"] and r["amp_pairs"] > 0,
    "06_train": lambda r: (
        r["iterations"] >= 2
        and r["finite"]
        and r["style_reward_last"] < r["style_reward_first"]
        and r["rollout_frames"] > 0
    ),
}


def _read(path: Path) -> dict[str, Any]:
    return json.loads(path.read_text())


def test_one_notebook_per_stage() -> None:
    assert tuple(p.stem for p in sorted(FOLDER.glob("*.ipynb"))) == STAGES


@pytest.mark.parametrize("name", STAGES)
def test_saved_without_outputs(name: str) -> None:
    """Outputs stay out of git: no outputs, no execution counts; the parameters come first."""
    notebook = _read(FOLDER / f"{name}.ipynb")
    assert notebook["nbformat"] == 4
    code = [cell for cell in notebook["cells"] if cell["cell_type"] == "code"]
    for cell in code:
        assert cell["outputs"] == [], f"{name}.ipynb: a cell has outputs (clear them)"
        assert cell["execution_count"] is None, f"{name}.ipynb: a cell has an execution count"
    first = "".join(code[0]["source"])
    assert "parameters" in code[0]["metadata"].get("tags", [])
    assert "MOTIONKIT_NB_SMALL" in first
    assert notebook["cells"][0]["cell_type"] == "markdown"
    assert "".join(notebook["cells"][0]["source"]).startswith("# ")
    assert "RESULT" in "".join(code[-1]["source"]) and "assert" in "".join(code[-1]["source"])


def _image_count(cells: list[Any]) -> int:
    return sum(
        "image/png" in output.get("data", {})
        for cell in cells
        if cell.cell_type == "code"
        for output in cell.outputs
    )


def _result(cells: list[Any]) -> dict[str, Any]:
    last = [cell for cell in cells if cell.cell_type == "code"][-1]
    text = "".join(o.get("text", "") for o in last.outputs if o.output_type == "stream")
    lines = [line for line in text.splitlines() if line.startswith("RESULT ")]
    assert lines, f"the checks cell printed no RESULT line:\n{text}"
    return json.loads(lines[-1][len("RESULT ") :])


@pytest.mark.slow
@pytest.mark.parametrize("name", STAGES)
def test_notebook_runs(name: str, tmp_path: Path) -> None:
    nbformat = pytest.importorskip("nbformat")
    nbclient = pytest.importorskip("nbclient")
    pytest.importorskip("ipykernel")
    for module in NEEDS[name]:
        pytest.importorskip(module)
    notebook = nbformat.read(FOLDER / f"{name}.ipynb", as_version=4)
    env = dict(os.environ)  # the session's private MOTIONKIT_CACHE included
    env["PYTHONPATH"] = os.pathsep.join(filter(None, [str(ROOT), env.get("PYTHONPATH")]))
    env["MOTIONKIT_NB_SMALL"] = "1"
    env["MOTIONKIT_NB_OUT"] = str(tmp_path / "out")
    env.pop("MOCAP_DIR", None)  # the retarget notebook: the packaged sample, not a local clip
    env.pop("MPLBACKEND", None)  # the kernel's inline backend, so that figures become outputs
    client = nbclient.NotebookClient(
        notebook,
        timeout=CELL_TIMEOUT,
        kernel_name="python3",
        resources={"metadata": {"path": str(tmp_path)}},  # the kernel's working directory
    )
    start = time.perf_counter()
    client.execute(env=env)  # raises CellExecutionError naming the failing cell
    print(f"{name}: executed in {time.perf_counter() - start:.1f} s")
    assert _image_count(notebook.cells) >= 1, f"{name}: no figure was drawn"
    result = _result(notebook.cells)
    assert EXPECT[name](result), result
