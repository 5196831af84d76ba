"""Exact sparse derivatives of a sum of small functions, assembled from their local derivatives.

The NLP's constraints and cost are sums of per-knot and per-interval terms. Instead of letting
CasADi differentiate the whole mapped graph (many sweeps over every knot, ~0.4 s per Hessian
at N = 20), each term's Jacobian and Hessian are computed as small SX functions, mapped over
the knots, and their nonzeros summed into the global sparse matrix by one constant sparse
matrix product.
"""

from __future__ import annotations

from collections.abc import Sequence

import casadi as cs
import numpy as np


class Scatter:
    """Sums `count` copies of a local sparse block (pattern `local`) into a global matrix.

    rows[i] and cols[i] map the local row and column indices of copy i to global ones.
    """

    def __init__(
        self,
        local: cs.Sparsity,
        rows: Sequence[np.ndarray],
        cols: Sequence[np.ndarray],
        shape: tuple[int, int],
    ) -> None:
        local_rows = np.array(local.row())
        local_cols = np.array(local.get_col())
        global_rows = np.concatenate([r[local_rows] for r in rows])
        global_cols = np.concatenate([c[local_cols] for c in cols])
        self.sparsity, mapping = cs.Sparsity.triplet(
            shape[0], shape[1], global_rows.tolist(), global_cols.tolist(), True
        )
        entries = len(mapping)
        pattern = cs.Sparsity.triplet(
            self.sparsity.nnz(), entries, list(mapping), list(range(entries))
        )
        self.summation = cs.DM(pattern, 1.0)

    def __call__(self, blocks: cs.MX) -> cs.MX:
        """`blocks`: the copies side by side (the output of a mapped function)."""
        nonzeros = cs.sparsity_cast(blocks, cs.Sparsity.dense(blocks.nnz(), 1))
        return cs.sparsity_cast(cs.mtimes(self.summation, nonzeros), self.sparsity)
