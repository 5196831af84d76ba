"""Checkpoints: the `Learner` (policy, discriminator, optimisers, normalisers, learning rate,
iteration) as flax msgpack bytes, written atomically. The replay buffer and the environments
are not saved: a resumed run starts fresh episodes and refills the buffer in one iteration."""

from __future__ import annotations

from pathlib import Path

import jax
import numpy as np
from flax import serialization

from motionkit.errors import TrainError
from motionkit.outputs import atomic_output
from motionkit.train.train import Learner

NAME = "checkpoint.msgpack"


def save_checkpoint(path: Path, learner: Learner) -> None:
    with atomic_output(Path(path)) as stream:
        stream.write(serialization.to_bytes(jax.device_get(learner)))


def load_checkpoint(path: Path, template: Learner) -> Learner:
    """The learner in `path`, checked against `template` (same networks and sizes)."""
    try:
        data = Path(path).read_bytes()
    except OSError as exc:
        raise TrainError(f"{path}: cannot read the checkpoint ({exc.strerror})") from exc
    try:
        restored = serialization.from_bytes(template, data)
    except (ValueError, KeyError, TypeError) as exc:
        raise TrainError(f"{path}: not a checkpoint of this config ({exc})") from exc
    expected = jax.tree.map(np.shape, template)
    found = jax.tree.map(np.shape, restored)
    if expected != found:
        raise TrainError(f"{path}: the checkpoint's networks differ from the config's")
    return jax.tree.map(jax.numpy.asarray, restored)
