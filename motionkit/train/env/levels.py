"""The curriculum of levels on a course (legged_gym's rule): each environment keeps a tile, its
kind fixed and its level moving from episode to episode. A robot whose episode reached its
route moves up a level, one that fell moves down (to level 0 at the lowest), and one that moves
up past the top level goes to a random level. Evaluations hold their tiles still."""

from __future__ import annotations

import jax
import jax.numpy as jnp
from flax import struct


@struct.dataclass
class Tile:
    """The tile an environment's episodes run on."""

    level: jax.Array  # int32
    kind: jax.Array  # int32, the index of the kind in the course's kinds
    moves: jax.Array  # bool: the level follows the curriculum (training) or stays (evaluation)


def first_tile(key: jax.Array, kinds: int, max_level: int, moves: bool = True) -> Tile:
    """A training environment's first tile: a random kind, a level from 0 to max_level, that
    follows the curriculum (`moves`) or stays."""
    k_kind, k_level = jax.random.split(key)
    return Tile(
        level=jax.random.randint(k_level, (), 0, max_level + 1),
        kind=jax.random.randint(k_kind, (), 0, kinds),
        moves=jnp.array(moves),
    )


def evaluation_tile(key: jax.Array, kinds: int, levels: int) -> Tile:
    """A tile held still: a random kind and level of the whole course."""
    k_kind, k_level = jax.random.split(key)
    return Tile(
        level=jax.random.randint(k_level, (), 0, levels),
        kind=jax.random.randint(k_kind, (), 0, kinds),
        moves=jnp.array(False),
    )


def fixed_tile(level: int, kind: int) -> Tile:
    """This tile, held still."""
    return Tile(jnp.array(level, jnp.int32), jnp.array(kind, jnp.int32), jnp.array(False))


def next_tile(key: jax.Array, tile: Tile, up: jax.Array, down: jax.Array, levels: int) -> Tile:
    """The tile of the next episode: one level up after `up`, one down after `down` (which wins
    over `up`), the same otherwise; past the top, a random level. A tile that does not move
    stays."""
    step = jnp.where(down, -1, jnp.where(up, 1, 0))
    level = tile.level + step
    level = jnp.where(
        level >= levels, jax.random.randint(key, (), 0, levels), jnp.maximum(level, 0)
    )
    return tile.replace(level=jnp.where(tile.moves, level, tile.level).astype(jnp.int32))
