"""CSR structure and edge lengths of the k-NN graph (numba; validated input)."""

from __future__ import annotations

import numpy as np
from numba import njit, prange

__all__ = ["edge_lengths", "graph_structure"]


@njit(cache=True)
def _sort_ints(a, lo, hi):
    m = hi - lo
    if m <= 24:
        for p in range(lo + 1, hi):
            v = a[p]
            q = p
            while q > lo and a[q - 1] > v:
                a[q] = a[q - 1]
                q -= 1
            a[q] = v
    else:
        a[lo:hi] = np.sort(a[lo:hi])


@njit(cache=True, parallel=True)
def graph_structure(nbr, n, symmetric):
    """CSR structure (sorted, duplicate-free columns) of the k-NN graph.

    ``nbr`` holds the neighbours of every point without the point itself.
    """
    m = nbr.shape[1]
    deg = np.zeros(n, dtype=np.int64)
    for i in range(n):
        deg[i] += m
        if symmetric:
            for c in range(m):
                deg[nbr[i, c]] += 1
    ptr = np.zeros(n + 1, dtype=np.int64)
    for i in range(n):
        ptr[i + 1] = ptr[i] + deg[i]
    cols = np.empty(ptr[n], dtype=np.int64)
    pos = ptr[:-1].copy()
    for i in range(n):
        for c in range(m):
            j = nbr[i, c]
            cols[pos[i]] = j
            pos[i] += 1
            if symmetric:
                cols[pos[j]] = i
                pos[j] += 1
    new_deg = np.zeros(n, dtype=np.int64)
    for i in prange(n):
        a = ptr[i]
        b = ptr[i + 1]
        _sort_ints(cols, a, b)
        w = a
        for p in range(a, b):
            if p == a or cols[p] != cols[p - 1]:
                cols[w] = cols[p]
                w += 1
        new_deg[i] = w - a
    indptr = np.zeros(n + 1, dtype=np.int64)
    for i in range(n):
        indptr[i + 1] = indptr[i] + new_deg[i]
    out = np.empty(indptr[n], dtype=np.int64)
    for i in prange(n):
        out[indptr[i] : indptr[i + 1]] = cols[ptr[i] : ptr[i] + new_deg[i]]
    return indptr, out


@njit(cache=True, parallel=True)
def edge_lengths(pts, indptr, cols):
    """Euclidean length of every stored edge (row i, column cols[p])."""
    n = indptr.shape[0] - 1
    out = np.empty(cols.shape[0])
    for i in prange(n):
        for p in range(indptr[i], indptr[i + 1]):
            j = cols[p]
            dx = pts[j, 0] - pts[i, 0]
            dy = pts[j, 1] - pts[i, 1]
            dz = pts[j, 2] - pts[i, 2]
            out[p] = np.sqrt(dx * dx + dy * dy + dz * dz)
    return out
