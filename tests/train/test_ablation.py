"""The ablation's radar chart and table from given figures, and its run over the four
settings with training replaced by a stand-in (the training runs are test_training's)."""

import json
from pathlib import Path

import numpy as np
import pytest

from motionkit.core.errors import TrainError
from motionkit.files.outputs import claim_out
from motionkit.train.ablation import AXES, SETTINGS, TABLE, metrics_table, radar_chart, run_ablation
from motionkit.train.config import PriorConfig, TrainConfig


def test_radar_chart_png(tmp_path: Path) -> None:
    figures = {
        setting: {axis: float(i + j + 1) for j, axis in enumerate(AXES)}
        for i, setting in enumerate(SETTINGS)
    }
    figures["none"]["task reward"] = -0.5  # negative rewards still draw
    path = tmp_path / "ablation.png"
    radar_chart(path, figures)
    import matplotlib.image

    image = matplotlib.image.imread(path)
    assert image.shape[0] > 300 and image.shape[1] > 300
    assert np.unique(image.reshape(-1, image.shape[-1]), axis=0).shape[0] > 50  # not blank
    assert list(SETTINGS) == ["walk+flight", "walk", "flight", "none"]


def test_metrics_table_by_hand() -> None:
    evaluations = {
        "walk+flight": {key: 0.5 for key in TABLE.values()} | {"eval_episode_seconds": 9.87654},
        "none": {"eval_task_reward": -0.25, "eval_approach_speed": float("nan")},
    }
    lines = metrics_table(evaluations).splitlines()
    assert lines[0] == "| setting | " + " | ".join(TABLE) + " |"
    assert lines[1] == "|---" * 8 + "|"
    assert lines[2] == "| walk+flight | 9.88 | " + " | ".join(["0.5"] * 6) + " |"
    # missing and NaN figures are n/a; the columns keep TABLE's order
    assert lines[3] == "| none | n/a | -0.25 | n/a | n/a | n/a | n/a | n/a |"
    assert len(lines) == 4


def test_run_ablation_writes_its_outputs_and_keeps_finished_runs(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The four settings' priors reach train(); a setting whose summary.json exists is not
    trained again; the chart, table and JSON carry each setting's evaluation."""
    import motionkit.train.runner as run

    trained: dict[str, list[str]] = {}

    def fake_train(config: TrainConfig, out: Path, robot: object, progress: object) -> dict:
        trained[out.name] = sorted(config.priors)
        seconds = 1.0 + len(trained)
        return {"eval": {"eval_episode_seconds": seconds, "eval_task_reward": 0.5}}

    monkeypatch.setattr(run, "train", fake_train)
    config = TrainConfig(
        priors={"walk": PriorConfig(("w",)), "flight": PriorConfig(("f",))},
    )
    claim_out(tmp_path, ["none"], TrainError)  # as an earlier, interrupted ablation left it
    kept = tmp_path / "none"
    kept.mkdir()
    (kept / "summary.json").write_text(json.dumps({"eval": {"eval_episode_seconds": 10.0}}))
    result = run_ablation(config, tmp_path, robot=None, progress=lambda _: None)

    assert trained == {"walk_flight": ["flight", "walk"], "walk": ["walk"], "flight": ["flight"]}
    assert result["figures"]["none"]["episode duration [s]"] == 10.0
    assert result["figures"]["flight"]["episode duration [s]"] == 4.0
    saved = json.loads((tmp_path / "ablation.json").read_text())
    assert saved["evaluations"]["walk"] == {"eval_episode_seconds": 3.0, "eval_task_reward": 0.5}
    table = (tmp_path / "ablation.md").read_text()
    assert table == result["table"] and "| none | 10 | n/a |" in table
    assert (tmp_path / "ablation.png").stat().st_size > 10_000
