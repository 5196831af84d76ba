"""Checkpoints: the `Learner` (policy, discriminator, optimisers, normalisers, learning rate,
iteration) as flax msgpack bytes, written atomically. The replay buffer and the environments
are not saved: a resumed run starts fresh episodes and refills the buffer in one iteration.

A slim checkpoint leaves out the optimisers' moments (two thirds of the bytes: Adam keeps two
per parameter), small enough to carry between machines or keep in a repository; a run resumed
from one starts its moments afresh and keeps all else (the adapted learning rate too)."""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import jax
import numpy as np
from flax import serialization

from motionkit.core.errors import TrainError
from motionkit.files.outputs import atomic_output, claim_out
from motionkit.train.learner import Learner

NAME = "checkpoint.msgpack"
SLIM_NAME = "checkpoint_slim.msgpack"
OPTIMISERS = ("policy_opt", "disc_opt")  # the Learner fields a slim checkpoint leaves out


def save_checkpoint(path: Path, learner: Learner) -> None:
    with atomic_output(Path(path)) as stream:
        stream.write(serialization.to_bytes(jax.device_get(learner)))


def write_slim(checkpoint: Path, path: Path) -> int:
    """The checkpoint at `checkpoint` without its optimisers' moments, written to `path`; its
    size in bytes."""
    return _write_slim(_state(Path(checkpoint)), Path(path))


def save_slim(path: Path, learner: Learner) -> int:
    """`learner` as a slim checkpoint at `path`; its size in bytes."""
    return _write_slim(serialization.to_state_dict(jax.device_get(learner)), Path(path))


def _write_slim(state: dict[str, Any], path: Path) -> int:
    data = serialization.msgpack_serialize({k: v for k, v in state.items() if k not in OPTIMISERS})
    with atomic_output(path) as stream:
        stream.write(data)
    return len(data)


def load_checkpoint(path: Path, template: Learner) -> tuple[Learner, bool]:
    """The learner in `path`, checked against `template` (same networks and sizes), and whether
    the checkpoint was slim (its optimisers' moments are then the template's)."""
    state = _state(Path(path))
    slim = not any(name in state for name in OPTIMISERS)
    if slim:
        state |= {name: serialization.to_state_dict(getattr(template, name)) for name in OPTIMISERS}
    try:
        restored = serialization.from_state_dict(template, state)
    except (ValueError, KeyError, TypeError) as exc:
        raise TrainError(f"{path}: not a checkpoint of this config ({exc})") from exc
    expected = jax.tree.map(np.shape, template)
    found = jax.tree.map(np.shape, restored)
    if expected != found:
        raise TrainError(f"{path}: the checkpoint's networks differ from the config's")
    return jax.tree.map(jax.numpy.asarray, restored), slim


def _state(path: Path) -> dict[str, Any]:
    """The checkpoint's state dict (msgpack), or TrainError naming what is wrong."""
    try:
        data = path.read_bytes()
    except OSError as exc:
        raise TrainError(f"{path}: cannot read the checkpoint ({exc.strerror})") from exc
    try:
        state = serialization.msgpack_restore(data)
    except Exception as exc:  # msgpack's errors for truncated or foreign bytes
        raise TrainError(f"{path}: not a checkpoint (unreadable msgpack: {exc})") from exc
    if not isinstance(state, dict) or "policy" not in state:
        raise TrainError(f"{path}: not a checkpoint (no policy in it)")
    return state


def place_checkpoint(out: Path, source: Path, option: str) -> bool:
    """Put checkpoint `source` (a file, maybe carried from another machine) into run folder
    `out` to resume from, claimed as motionkit's; True when it was copied, False when it is
    the run's own. A TrainError naming `option` when `source` is missing or `out` holds
    another run."""
    out, source = Path(out), Path(source)
    checkpoint = out / NAME
    if not source.is_file():
        raise TrainError(f"{option} {source}: no such checkpoint file")
    if checkpoint.exists():
        if os.path.samefile(checkpoint, source):
            return False
        raise TrainError(
            f"{option} {source}: {out} holds another run ({checkpoint}); resume into a new "
            f"--out, or pass {option} {checkpoint}"
        )
    claim_out(out, [NAME], TrainError)  # motionkit's: the trainer may resume from it
    with atomic_output(checkpoint) as stream:
        stream.write(source.read_bytes())
    return True
