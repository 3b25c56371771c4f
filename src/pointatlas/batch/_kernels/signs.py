"""Orientation pieces joined across tiles: a maximum spanning forest of their votes and
the relative sign of every piece in its tree (numba).

The stitching of tiled MST normals (docs/decisions/batch.md, "Tiles — normals")
joins pieces along the strongest votes first; the edge order is given (sorted by the
caller), so the forest is Kruskal's in that order. Validated input assumed. Tested
against a plain Python Kruskal in `tests/batch/test_tiles_signs.py`.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from ..._core.kernels import find_root

__all__ = ["signed_forest_kernel"]


@njit(cache=True)
def signed_forest_kernel(n, ea, eb, positive):
    """Kruskal's forest over edges in the given order, then every node's sign
    relative to the smallest node of its tree.

    Parameters
    ----------
    n : int
        Number of nodes.
    ea, eb : ndarray of shape (m,), int64
        Edge ends (node numbers), in the order edges are tried.
    positive : ndarray of shape (m,), bool
        True where an edge says "same sign", False for "opposite".

    Returns
    -------
    comp : ndarray of shape (n,), int64
        Tree of every node, numbered in the order of their smallest node.
    rel : ndarray of shape (n,), float64
        +1 / -1: the product of the edge signs on the path from the tree's smallest
        node.
    """
    parent = np.arange(n)
    keep = np.zeros(ea.size, dtype=np.bool_)
    deg = np.zeros(n + 1, dtype=np.int64)
    for e in range(ea.size):
        ra = find_root(parent, ea[e])
        rb = find_root(parent, eb[e])
        if ra != rb:
            parent[rb] = ra
            keep[e] = True
            deg[ea[e] + 1] += 1
            deg[eb[e] + 1] += 1
    start = np.cumsum(deg)
    fill = start[:n].copy()
    nbr = np.empty(start[n], dtype=np.int64)
    sgn = np.empty(start[n], dtype=np.float64)
    for e in range(ea.size):
        if keep[e]:
            s = 1.0 if positive[e] else -1.0
            a, b = ea[e], eb[e]
            nbr[fill[a]] = b
            sgn[fill[a]] = s
            fill[a] += 1
            nbr[fill[b]] = a
            sgn[fill[b]] = s
            fill[b] += 1
    comp = np.full(n, -1, dtype=np.int64)
    rel = np.zeros(n, dtype=np.float64)
    stack = np.empty(n, dtype=np.int64)
    m = 0
    for r in range(n):
        if comp[r] >= 0:
            continue
        comp[r] = m
        rel[r] = 1.0
        stack[0] = r
        top = 1
        while top > 0:
            top -= 1
            u = stack[top]
            for p in range(start[u], start[u + 1]):
                w = nbr[p]
                if comp[w] < 0:
                    comp[w] = m
                    rel[w] = rel[u] * sgn[p]
                    stack[top] = w
                    top += 1
        m += 1
    return comp, rel
