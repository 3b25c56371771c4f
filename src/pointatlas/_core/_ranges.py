"""Index range of a neighbour table (numba; imported lazily by `check_neighbors`)."""

from __future__ import annotations

from numba import njit


@njit(cache=True)
def index_range(table):
    """(min, max) of a non-empty (N, k) int64 table in one pass (numpy's ``min`` and
    ``max`` take two). Serial: a few milliseconds per million rows, less than numba
    takes to compile a parallel loop."""
    lo = table[0, 0]
    hi = lo
    for t in range(table.shape[0]):
        for j in range(table.shape[1]):
            v = table[t, j]
            if v < lo:
                lo = v
            if v > hi:
                hi = v
    return lo, hi
