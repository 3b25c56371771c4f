"""A 4-ary min-heap on three arrays (numba), for the collapse loop
(`_kernels.collapse_edges`): entries ``(cost, key, data)`` first by cost, then by key
(an edge's ends, ``a * V + b``: the order of the tuples ``(cost, a, b, ...)`` that
`heapq` popped before, for every pair of entries whose cost or ends differ); ``data``
rides along.

Why not `heapq` on a list of tuples: the collapse loop pops about ten entries per
collapse (all but one stale: every collapse pushes every edge of its vertex again),
and numba's list moved eight-field tuples through a binary heap; three flat arrays
and four children per node halve the levels and the bytes moved (a stand-alone run
of the pushes and pops of a 120,000-triangle decimation: 0.33 -> 0.15 s).
"""

from __future__ import annotations

import numpy as np
from numba import njit

__all__ = ["heap_grown", "heap_pop", "heap_push", "heapify"]


@njit(cache=True, inline="always")
def _first(c0, k0, c1, k1) -> bool:
    """Whether entry (c0, k0) comes before (c1, k1)."""
    return c0 < c1 or (c0 == c1 and k0 < k1)


@njit(cache=True)
def _sift_down(cost, key, data, n, i, c, k, d) -> None:
    """Entry (c, k, d) into the hole at ``i`` of a heap of ``n`` entries: down past
    every child that comes before it."""
    while True:
        first = 4 * i + 1
        if first >= n:
            break
        best = first
        for j in range(first + 1, min(first + 4, n)):
            if _first(cost[j], key[j], cost[best], key[best]):
                best = j
        if not _first(cost[best], key[best], c, k):
            break
        cost[i], key[i], data[i] = cost[best], key[best], data[best]
        i = best
    cost[i], key[i], data[i] = c, k, d


@njit(cache=True)
def heapify(cost, key, data, n) -> None:
    """The first ``n`` entries of the arrays made a heap."""
    for i in range((n - 2) // 4, -1, -1):
        _sift_down(cost, key, data, n, i, cost[i], key[i], data[i])


@njit(cache=True)
def heap_push(cost, key, data, n, c, k, d) -> None:
    """Entry (c, k, d) onto a heap of ``n`` entries (the arrays hold at least n + 1)."""
    i = n
    while i > 0:
        up = (i - 1) >> 2
        if not _first(c, k, cost[up], key[up]):
            break
        cost[i], key[i], data[i] = cost[up], key[up], data[up]
        i = up
    cost[i], key[i], data[i] = c, k, d


@njit(cache=True)
def heap_pop(cost, key, data, n):
    """The first entry ``(cost, key, data)`` of a heap of ``n`` > 0 entries, taken off
    (n - 1 left)."""
    top = (cost[0], key[0], data[0])
    if n > 1:
        _sift_down(cost, key, data, n - 1, 0, cost[n - 1], key[n - 1], data[n - 1])
    return top


@njit(cache=True)
def heap_grown(cost, key, data, n, more):
    """The arrays of a heap of ``n`` entries, room for ``more`` entries made (twice
    the size, or as much as needed, when they are short)."""
    if n + more <= cost.shape[0]:
        return cost, key, data
    size = max(2 * cost.shape[0], n + more)
    c, k, d = np.empty(size), np.empty(size, np.int64), np.empty(size, np.int64)
    c[:n], k[:n], d[:n] = cost[:n], key[:n], data[:n]
    return c, k, d
