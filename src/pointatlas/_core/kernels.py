"""numba kernels shared by several rooms: a union-find and per-axis bounds.

A public module of `pointatlas._core` (as `errors` and `tolerances`), imported by
its own name: `pointatlas._core` itself does not import it, so importing a room that
needs no numba stays free of it. ``segment`` (connected label components) and
``batch`` (orientation pieces and their spanning forest) share the union-find;
``neighbors`` (the grid) and ``batch`` (a source's extent) share `bounds`.
Validated input assumed: the kernels check nothing.
"""

from __future__ import annotations

from numba import njit

__all__ = ["bounds", "find_root", "union_min"]


@njit(cache=True)
def bounds(pts):
    """Per-axis minimum and maximum of a point array, in one pass.

    Parameters
    ----------
    pts : (N, 3) float64 array
        N >= 1 rows.

    Returns
    -------
    lo, hi : (3,) float64 arrays
        ``pts.min(axis=0)`` and ``pts.max(axis=0)`` (numpy's strided axis-0
        reductions are slow).
    """
    lo = pts[0].copy()
    hi = pts[0].copy()
    for p in range(1, pts.shape[0]):
        for d in range(3):
            v = pts[p, d]
            if v < lo[d]:
                lo[d] = v
            if v > hi[d]:
                hi[d] = v
    return lo, hi


@njit(cache=True)
def find_root(parent, i):
    """Root of ``i`` in a union-find forest, compressing the path to it.

    Parameters
    ----------
    parent : (N,) int64 array
        The forest: ``parent[r] == r`` at a root; the path from ``i`` is made to
        point at the root.
    i : int
        A node, 0 <= i < N.

    Returns
    -------
    root : int
        The root of the tree that holds ``i``.
    """
    root = i
    while parent[root] != root:
        root = parent[root]
    while parent[i] != root:  # path compression
        nxt = parent[i]
        parent[i] = root
        i = nxt
    return root


@njit(cache=True, inline="always")
def union_min(parent, i, j):
    """Join the sets of ``i`` and ``j`` under the smaller of their two roots.

    Parameters
    ----------
    parent : (N,) int64 array
        The union-find forest of `find_root`, changed in place.
    i, j : int
        Two nodes; nothing changes when they share a root already.

    Notes
    -----
    Every root is the smallest node of its set when the forest starts with
    ``parent[i] == i`` and only this joins sets.
    """
    ri = find_root(parent, i)
    rj = find_root(parent, j)
    if ri != rj:
        if ri < rj:
            parent[rj] = ri
        else:
            parent[ri] = rj
