"""Checkpoints round-trip the learner exactly; a slim one leaves out the optimisers' moments,
which a resume then takes fresh from the run's own; foreign and mismatched files are refused."""

from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np
import optax
import pytest
from flax import serialization

from motionkit.core.errors import TrainError
from motionkit.train.checkpoint import load_checkpoint, save_checkpoint, write_slim
from motionkit.train.learner import Learner
from motionkit.train.normalize import RunningNorm


def learner(seed: int, width: int = 8) -> Learner:
    """A small learner: two-layer policy and discriminator, Adam states after one update."""
    keys = jax.random.split(jax.random.key(seed), 4)
    policy = {
        "w1": jax.random.normal(keys[0], (5, width)),
        "w2": jax.random.normal(keys[1], (width, 3)),
    }
    disc = {"w": jax.random.normal(keys[2], (7, width)), "b": jax.random.normal(keys[3], (width,))}
    adam = optax.adam(1e-3)

    def stepped(params):  # moments that are not zero: one update with the params as gradient
        return adam.update(params, adam.init(params), params)[1]

    return Learner(
        policy=policy,
        policy_opt=stepped(policy),
        learning_rate=jnp.array(3e-4 * (seed + 1)),
        disc=disc,
        disc_opt=stepped(disc),
        obs_norm=RunningNorm(jnp.full(5, float(seed)), jnp.ones(5), jnp.array(10.0)),
        amp_norm=RunningNorm.create(7),
        iteration=jnp.array(40 + seed),
        env_steps=jnp.array(1000 * seed),
    )


def same(a, b) -> bool:
    return all(
        np.array_equal(x, y) for x, y in zip(jax.tree.leaves(a), jax.tree.leaves(b), strict=True)
    )


def test_a_full_checkpoint_round_trips(tmp_path: Path) -> None:
    saved, template = learner(1), learner(2)
    save_checkpoint(tmp_path / "c.msgpack", saved)
    restored, slim = load_checkpoint(tmp_path / "c.msgpack", template)
    assert not slim and same(restored, saved) and not same(restored, template)


def test_a_slim_checkpoint_keeps_all_but_the_moments(tmp_path: Path) -> None:
    saved, template = learner(1, width=64), learner(2, width=64)
    full, thin = tmp_path / "c.msgpack", tmp_path / "slim.msgpack"
    save_checkpoint(full, saved)
    size = write_slim(full, thin)
    assert size == thin.stat().st_size
    # Adam keeps two moments per parameter: a third of the bytes remains (and the counts)
    assert 0.3 < size / full.stat().st_size < 0.36
    restored, slim = load_checkpoint(thin, template)
    assert slim
    for field in ("policy", "disc", "learning_rate", "obs_norm", "iteration", "env_steps"):
        assert same(getattr(restored, field), getattr(saved, field)), field
    assert same(restored.policy_opt, template.policy_opt)  # the run's own, fresh moments
    assert same(restored.disc_opt, template.disc_opt)
    state = serialization.msgpack_restore(thin.read_bytes())
    assert "policy_opt" not in state and "disc_opt" not in state


def test_foreign_and_mismatched_checkpoints_are_refused(tmp_path: Path) -> None:
    path = tmp_path / "c.msgpack"
    path.write_bytes(b"\x93not a checkpoint")
    with pytest.raises(TrainError, match="not a checkpoint \\(unreadable msgpack"):
        load_checkpoint(path, learner(0))
    path.write_bytes(serialization.msgpack_serialize({"weights": np.zeros(3)}))
    with pytest.raises(TrainError, match="not a checkpoint \\(no policy in it\\)"):
        load_checkpoint(path, learner(0))
    save_checkpoint(path, learner(0, width=16))
    with pytest.raises(TrainError, match="networks differ from the config's"):
        load_checkpoint(path, learner(0, width=8))
    with pytest.raises(TrainError, match="cannot read the checkpoint"):
        write_slim(tmp_path / "missing.msgpack", tmp_path / "slim.msgpack")
    assert not (tmp_path / "slim.msgpack").exists()
