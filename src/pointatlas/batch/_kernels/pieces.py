"""Orientation pieces of a tile: components of its k-NN graph over smooth edges (numba).

A tile's MST orientation (Hoppe) is reliable within a piece, where neighbouring
normals make less than 10 degrees; across sharp edges (a wall on the ground) it
guesses, so the stitching joins pieces by halo votes (docs/decisions/batch.md,
"Tiles — normals"). Validated input assumed. Tested against scipy's
``connected_components`` (`tests/batch/test_kernels.py`).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from ..._core.kernels import find_root, union_min

__all__ = ["piece_tops_kernel", "smooth_pieces_kernel"]


@njit(cache=True, inline="always")
def _dot(normals, i, j):
    d = normals[i, 0] * normals[j, 0] + normals[i, 1] * normals[j, 1]
    return d + normals[i, 2] * normals[j, 2]


@njit(cache=True)
def smooth_pieces_kernel(table, normals, min_cos):
    """Pieces over smooth edges and the sharp edges between pieces.

    Parameters
    ----------
    table : ndarray of shape (n, k), int64
        The tile's k-NN graph (row i: neighbours of point i).
    normals : ndarray of shape (n, 3), float64
        Oriented normals of the tile's points.
    min_cos : float
        An edge (i, j) is smooth when ``|n_i . n_j| >= min_cos``.

    Returns
    -------
    labels : ndarray of shape (n,), int64
        Piece of every point, numbered in the order of their smallest point
        (the numbering of scipy's ``connected_components``).
    a, b : ndarray of shape (m,), int64
        Pieces (a < b) of every sharp edge between two different pieces, in
        edge order (row, then column).
    dots : ndarray of shape (m,), float64
        ``n_i . n_j`` of those edges.
    """
    n, k = table.shape
    parent = np.arange(n)
    sharp = np.empty((n, k), dtype=np.bool_)  # the edges' test, made once
    n_sharp = 0
    for i in range(n):
        for c in range(k):
            j = table[i, c]
            smooth = abs(_dot(normals, i, j)) >= min_cos
            sharp[i, c] = not smooth
            if smooth:
                union_min(parent, i, j)
            else:
                n_sharp += 1
    labels = np.empty(n, dtype=np.int64)
    rank = np.full(n, -1, dtype=np.int64)
    m = 0
    for i in range(n):
        r = find_root(parent, i)
        if rank[r] < 0:
            rank[r] = m
            m += 1
        labels[i] = rank[r]
    a = np.empty(n_sharp, dtype=np.int64)
    b = np.empty(n_sharp, dtype=np.int64)
    dots = np.empty(n_sharp, dtype=np.float64)
    e = 0
    for i in range(n):
        for c in range(k):
            j = table[i, c]
            if sharp[i, c] and labels[i] != labels[j]:
                a[e] = min(labels[i], labels[j])
                b[e] = max(labels[i], labels[j])
                dots[e] = _dot(normals, i, j)
                e += 1
    return labels, a[:e].copy(), b[:e].copy(), dots[:e].copy()


@njit(cache=True)
def piece_tops_kernel(labels, n_pieces, rows, z, gidx):
    """Per piece, the row of ``rows`` with the largest z (ties: the smallest global
    index ``gidx``); -1 for a piece without such a row."""
    best = np.full(n_pieces, -1, dtype=np.int64)
    for r in range(rows.shape[0]):
        i = rows[r]
        c = labels[i]
        b = best[c]
        if b < 0 or z[i] > z[b] or (z[i] == z[b] and gidx[i] < gidx[b]):
            best[c] = i
    return best
