"""The ablation's radar chart from given figures (the training runs are test_training's)."""

from pathlib import Path

import numpy as np

from motionkit.train.ablation import AXES, SETTINGS, radar_chart


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
