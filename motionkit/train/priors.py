"""Motion priors for the discriminator: the [priors.NAME] clips of a config as AMP transition
pairs at the control rate, each prior weighted by its `weight`."""

from __future__ import annotations

import numpy as np

from motionkit.dataset import MotionDataset
from motionkit.errors import DatasetError, TrainError
from motionkit.robot import Robot
from motionkit.train.amp import PriorData
from motionkit.train.config import PriorConfig


def load_priors(
    priors: dict[str, PriorConfig], robot: Robot, rate: float
) -> tuple[PriorData | None, dict[str, dict[str, float]]]:
    """The combined dataset transitions (None without priors) and a summary per prior."""
    if not priors:
        return None, {}
    currents, followings, probabilities, summary = [], [], [], {}
    total_weight = sum(p.weight for p in priors.values())
    for name, prior in priors.items():
        try:
            dataset = MotionDataset(list(prior.paths))
            pairs = dataset.amp_pairs(robot, rate)
        except DatasetError as exc:
            raise TrainError(f"prior '{name}': {exc}") from exc
        currents.append(pairs.current)
        followings.append(pairs.following)
        probabilities.append(pairs.probability * prior.weight / total_weight)
        summary[name] = {
            "clips": len(dataset),
            "seconds": round(dataset.duration, 3),
            "pairs": len(pairs.current),
            "weight": prior.weight,
        }
    data = PriorData.create(
        np.concatenate(currents), np.concatenate(followings), np.concatenate(probabilities)
    )
    return data, summary
