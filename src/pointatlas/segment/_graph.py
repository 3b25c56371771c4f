"""The neighbourhood graph shared by VSA and region growing, and region adjacency."""

from __future__ import annotations

import numpy as np
from scipy import sparse

from .._core import as_int, as_k, as_labels, as_points, check_neighbors
from .._core._sort import permute_table
from ..neighbors import query_knn
from ._kernels import boundary_points, region_pairs, symmetric_csr

__all__ = ["neighbor_graph", "region_adjacency"]


def _check_k(k, n_points: int, neighbors=None) -> int:
    """The room's rule for k: an integer counting the point itself, 1 <= k <= N.

    With a precomputed ``neighbors`` table or adjacency k is not used for the
    graph, so only k >= 1 is required.
    """
    if neighbors is None:
        return as_k(k, n_points)
    return as_int(k, "k", lo=1)


def neighbor_graph(points: np.ndarray, k: int, neighbors=None):
    """Symmetric neighbourhood graph as CSR (indptr, indices) plus the k-NN table.

    Private helper; ``points`` validated. ``neighbors`` may be None (k-NN of the
    points, k including the point itself), an (N, c) int table of neighbour
    indices (entries < 0 ignored; a column equal to the row is ignored), or a
    scipy sparse (N, N) adjacency whose structure is used.

    Returns (indptr, indices, knn) where ``knn`` is the (N, c) table or None when
    a sparse adjacency was given.
    """
    n = points.shape[0]
    if neighbors is None:
        knn = _knn_table(points, k)
        indptr, indices = symmetric_csr(np.ascontiguousarray(knn), n)
        return indptr, indices, knn
    if sparse.issparse(neighbors):
        coo = _check_adjacency(neighbors, n)
        rows = np.asarray(coo.row, dtype=np.int64)
        cols = np.asarray(coo.col, dtype=np.int64)
        keep = rows != cols
        rows, cols = rows[keep], cols[keep]
        rows, cols = np.concatenate([rows, cols]), np.concatenate([cols, rows])
        # distinct keys by one sort: numpy's hashing np.unique is ~15x slower here
        key = np.sort(rows * n + cols)
        key = key[np.concatenate([key[:1] >= 0, key[1:] != key[:-1]])]
        rows, cols = key // n, key % n
        indptr = np.zeros(n + 1, dtype=np.int64)
        np.cumsum(np.bincount(rows, minlength=n), out=indptr[1:])
        return indptr, cols.astype(np.int64), None
    table = check_neighbors(neighbors, n, allow_negative=True)
    indptr, indices = symmetric_csr(table, n)
    return indptr, indices, table


def _knn_table(points: np.ndarray, k: int) -> np.ndarray:
    """The (N, k) k-NN table of the points (the point itself included); k validated
    by the caller (`_check_k`)."""
    knn, _ = query_knn(points, k)
    return knn


def _check_adjacency(neighbors, n: int):
    """A scipy sparse (N, N) adjacency as a COO array, validated."""
    if neighbors.shape != (n, n):
        raise ValueError(
            f"neighbors must be an (N, N) adjacency with N = {n}; got {neighbors.shape}"
        )
    return sparse.coo_array(neighbors)


def permuted_neighbors(points: np.ndarray, k: int, neighbors, order: np.ndarray, inv: np.ndarray):
    """``neighbors`` (None, an (N, c) table or a sparse adjacency, as `neighbor_graph`
    takes it) for the points renumbered so that new point r is old point
    ``order[r]`` (``inv`` the inverse permutation); None becomes the k-NN table of
    the old points. Entries < 0 stay < 0; rows keep their column order.
    """
    n = points.shape[0]
    if neighbors is None:
        neighbors = _knn_table(points, k)
    elif sparse.issparse(neighbors):
        coo = _check_adjacency(neighbors, n)
        rows = inv[np.asarray(coo.row, dtype=np.int64)]
        cols = inv[np.asarray(coo.col, dtype=np.int64)]
        return sparse.coo_array((np.ones(rows.shape[0]), (rows, cols)), shape=(n, n))
    return permute_table(check_neighbors(neighbors, n, allow_negative=True), order, inv)


def region_adjacency(points, labels, *, k: int = 8, neighbors=None) -> np.ndarray:
    """Pairs of neighbouring regions (thesis Remark 6).

    Two regions are neighbours when a point of one has a point of the other among
    its k nearest neighbours (the symmetric k-NN graph).

    Parameters
    ----------
    points : array_like of shape (N, 3)
        Coordinates.
    labels : array_like of shape (N,), int
        Region of every point (>= 0).
    k : int
        Neighbourhood size, the point itself included (1 <= k <= N; only k >= 1
        is required when ``neighbors`` is given).
    neighbors : ndarray of shape (N, c) or scipy sparse (N, N), optional
        A precomputed neighbour table or adjacency instead of the k-NN query.

    Returns
    -------
    pairs : ndarray of shape (E, 2), int64
        Sorted region pairs (a < b).

    Raises
    ------
    ValueError
        Labels of the wrong shape or negative; k outside [1, N].
    TypeError
        k not an integer.

    Notes
    -----
    Remark 6 collects, for every point, all points within the distance of its
    k-th nearest neighbour; up to exact distance ties that is the k-NN set, whose
    symmetric closure is used here (decision in docs/decisions/segment.md).

    Examples
    --------
    >>> pts = [[0, 0, 0], [1, 0, 0], [2, 0, 0], [3, 0, 0]]
    >>> region_adjacency(pts, [0, 0, 1, 2], k=2).tolist()
    [[0, 1], [1, 2]]
    """
    pts = as_points(points)
    lab = as_labels(labels, pts.shape[0])
    if (lab < 0).any():
        raise ValueError("labels must be >= 0 (every point in a region)")
    k = _check_k(k, pts.shape[0], neighbors)
    indptr, indices, _ = neighbor_graph(pts, k, neighbors)
    return region_pairs(indptr, indices, lab, boundary_points(indptr, indices, lab))
