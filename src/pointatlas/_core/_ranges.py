"""Index range of a neighbour table (numba; imported lazily by `check_neighbors`)."""

from __future__ import annotations

import numpy as np
from numba import njit, prange

_RANGE_BLOCK = 1024  # rows per parallel block of `index_range`


@njit(parallel=True, cache=True, error_model="numpy")
def index_range(table):
    """(min, max) of a non-empty (N, k) int64 table, in parallel (one pass, not two)."""
    n = table.shape[0]
    n_blocks = (n + _RANGE_BLOCK - 1) // _RANGE_BLOCK
    block_min = np.empty(n_blocks, dtype=np.int64)
    block_max = np.empty(n_blocks, dtype=np.int64)
    for blk in prange(n_blocks):
        lo = table[blk * _RANGE_BLOCK, 0]
        hi = lo
        for t in range(blk * _RANGE_BLOCK, min(n, (blk + 1) * _RANGE_BLOCK)):
            for j in range(table.shape[1]):
                v = table[t, j]
                lo = min(lo, v)
                hi = max(hi, v)
        block_min[blk] = lo
        block_max[blk] = hi
    return block_min.min(), block_max.max()
