"""k-nearest and radius neighbourhoods with the GUIDE's deterministic tie-break.

Combinatorial neighbourhood (thesis Example 1 v, GUIDE conventions): the k nearest
points *including the point itself*. Decision (docs/decisions.md): column 0 is
always the point itself, even when exact duplicates with smaller indices exist;
the other k - 1 columns are the remaining points ordered by (distance, index), so
among equally distant candidates the smaller index wins and N^c is unique.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from .._core import PointAtlasError, as_points, readonly

__all__ = ["NeighborIndex", "RadiusNeighbors", "query_knn", "query_radius"]


def _check_k(k, n_points: int) -> int:
    if isinstance(k, bool) or not isinstance(k, int | np.integer):
        raise TypeError(f"k must be an integer; got {type(k).__name__}")
    k = int(k)
    if k < 1:
        raise ValueError(f"k must be >= 1; got {k}")
    if k > n_points:
        raise PointAtlasError(
            f"too few points for k: k = {k} neighbours (the point included) need at least "
            f"{k} points; got {n_points}"
        )
    return k


def _order_rows(idx: np.ndarray, dist: np.ndarray, self_idx: np.ndarray, k: int):
    """Sort candidate rows by (distance, index), put self first, keep k columns.

    ``idx``/``dist`` are (M, C) candidate arrays padded with index = huge and
    dist = inf; every row contains its own point.
    """
    order = np.lexsort((idx, dist), axis=-1)
    idx = np.take_along_axis(idx, order, axis=1)
    dist = np.take_along_axis(dist, order, axis=1)
    is_self = idx == self_idx[:, None]
    # drop the self column: stable selection of the others, then prepend self
    others_rank = np.cumsum(~is_self, axis=1) - 1
    keep = (~is_self) & (others_rank < k - 1)
    m = idx.shape[0]
    out_idx = np.empty((m, k), dtype=np.int64)
    out_dist = np.empty((m, k), dtype=np.float64)
    out_idx[:, 0] = self_idx
    out_dist[:, 0] = 0.0
    if k > 1:
        rows, cols = np.nonzero(keep)
        out_idx[rows, 1 + others_rank[rows, cols]] = idx[rows, cols]
        out_dist[rows, 1 + others_rank[rows, cols]] = dist[rows, cols]
    return out_idx, out_dist


class NeighborIndex:
    """A k-d tree over a point set, built once and queried many times.

    Parameters
    ----------
    points : array_like of shape (N, 3)
        Coordinates (validated; non-finite values raise).

    Notes
    -----
    Coordinates are centred on their bounding-box centre before the tree is built
    so distances keep their precision for UTM-like inputs. Exact ties are broken by
    smaller index (GUIDE conventions). The one-shot functions `query_knn` and
    `query_radius` wrap this class.

    Examples
    --------
    >>> idx = NeighborIndex([[0, 0, 0], [1, 0, 0], [3, 0, 0]])
    >>> idx.knn(2)[0].tolist()
    [[0, 1], [1, 0], [2, 1]]
    """

    def __init__(self, points):
        pts = as_points(points, min_points=1)
        self.center_ = 0.5 * (pts.min(axis=0) + pts.max(axis=0))
        self.points_ = readonly(pts - self.center_)
        self.tree_ = cKDTree(self.points_, balanced_tree=False, compact_nodes=False)

    @property
    def n_points(self) -> int:
        """Number of indexed points."""
        return int(self.points_.shape[0])

    def knn(self, k: int) -> tuple[np.ndarray, np.ndarray]:
        """k nearest neighbours of every indexed point, the point itself first.

        Parameters
        ----------
        k : int
            Neighbourhood size including the point itself (1 <= k <= N).

        Returns
        -------
        indices : ndarray of shape (N, k), int64
            Column 0 is the point itself; the rest by (distance, index).
        distances : ndarray of shape (N, k), float64
            Euclidean distances, non-decreasing along each row.

        Raises
        ------
        PointAtlasError
            k larger than the number of points.
        """
        n = self.n_points
        k = _check_k(k, n)
        kk = min(k + 1, n)
        dist, idx = self.tree_.query(self.points_, k=kk, workers=-1)
        dist = np.asarray(dist, dtype=np.float64).reshape(n, kk)
        idx = np.asarray(idx, dtype=np.int64).reshape(n, kk)
        self_idx = np.arange(n, dtype=np.int64)
        has_self = (idx == self_idx[:, None]).any(axis=1)
        if kk > k:
            boundary_tie = dist[:, k - 1] == dist[:, k]
        else:
            boundary_tie = np.zeros(n, dtype=bool)
        problem = np.flatnonzero(boundary_tie | ~has_self)
        out_idx, out_dist = _order_rows(idx, dist, self_idx, k)
        if problem.size:
            radius = dist[problem, k - 1] if kk > k else dist[problem, -1]
            fix_idx, fix_dist = self._ball_candidates(problem, radius)
            out_idx[problem], out_dist[problem] = _order_rows(fix_idx, fix_dist, problem, k)
        return out_idx, out_dist

    def _ball_candidates(self, rows: np.ndarray, radius: np.ndarray):
        """All points within ``radius`` (closed ball, slightly widened) of ``rows``."""
        r = radius * (1.0 + 1e-12) + 1e-300
        lists = self.tree_.query_ball_point(self.points_[rows], r, workers=-1)
        lengths = np.fromiter((len(v) for v in lists), dtype=np.int64, count=len(lists))
        flat = np.fromiter((j for v in lists for j in v), dtype=np.int64, count=lengths.sum())
        width = int(lengths.max())
        cand = np.full((rows.size, width), np.iinfo(np.int64).max, dtype=np.int64)
        col = np.arange(flat.size) - np.repeat(np.cumsum(lengths) - lengths, lengths)
        row = np.repeat(np.arange(rows.size), lengths)
        cand[row, col] = flat
        dist = np.full(cand.shape, np.inf)
        diff = self.points_[flat] - self.points_[rows[row]]
        dist[row, col] = np.sqrt(np.einsum("ij,ij->i", diff, diff))
        # the tree's own distances decide the ordering elsewhere; recompute with the
        # same formula here so exactly tied points compare equal
        return cand, dist

    def radius(self, radius: float) -> RadiusNeighbors:
        """All points within ``radius`` (closed ball) of every indexed point.

        Parameters
        ----------
        radius : float
            Ball radius in the input's units (> 0).

        Returns
        -------
        neighbors : RadiusNeighbors
            CSR-style arrays; each row starts with the point itself, then by
            (distance, index).
        """
        radius = float(radius)
        if not np.isfinite(radius) or radius <= 0:
            raise ValueError(f"radius must be a positive finite number; got {radius}")
        n = self.n_points
        lists = self.tree_.query_ball_point(self.points_, radius, workers=-1)
        lengths = np.fromiter((len(v) for v in lists), dtype=np.int64, count=n)
        flat = np.fromiter((j for v in lists for j in v), dtype=np.int64, count=lengths.sum())
        row = np.repeat(np.arange(n, dtype=np.int64), lengths)
        diff = self.points_[flat] - self.points_[row]
        dist = np.sqrt(np.einsum("ij,ij->i", diff, diff))
        not_self = (flat != row).astype(np.int8)
        order = np.lexsort((flat, dist, not_self, row))
        indptr = np.zeros(n + 1, dtype=np.int64)
        np.cumsum(lengths, out=indptr[1:])
        return RadiusNeighbors(indptr=indptr, indices=flat[order], distances=dist[order])


@dataclass(frozen=True, slots=True)
class RadiusNeighbors:
    """Geometric neighbourhoods (closed balls) in CSR form.

    Attributes
    ----------
    indptr : ndarray of shape (N + 1,), int64
        Row i's neighbours are ``indices[indptr[i]:indptr[i + 1]]``.
    indices : ndarray of shape (nnz,), int64
        Neighbour indices; each row starts with the point itself.
    distances : ndarray of shape (nnz,), float64
        Distances matching ``indices``.
    """

    indptr: np.ndarray
    indices: np.ndarray
    distances: np.ndarray

    def __post_init__(self):
        for name in ("indptr", "indices", "distances"):
            readonly(getattr(self, name))

    @property
    def counts(self) -> np.ndarray:
        """Neighbourhood sizes, ndarray of shape (N,), int64."""
        return np.diff(self.indptr)

    def row(self, i: int) -> np.ndarray:
        """Neighbour indices of point ``i``."""
        return self.indices[self.indptr[i] : self.indptr[i + 1]]


def query_knn(points, k: int) -> tuple[np.ndarray, np.ndarray]:
    """k nearest neighbours of every point, the point itself included and first.

    Parameters
    ----------
    points : array_like of shape (N, 3)
        Coordinates.
    k : int
        Neighbourhood size including the point itself (1 <= k <= N).

    Returns
    -------
    indices : ndarray of shape (N, k), int64
        Column 0 is the point itself; then by (distance, smaller index first).
    distances : ndarray of shape (N, k), float64
        Euclidean distances.

    Raises
    ------
    PointAtlasError
        k larger than the number of points.
    ValueError
        Non-finite or badly shaped points.

    Notes
    -----
    Combinatorial neighbourhood of thesis Example 1 (v) with the tie-break of the
    GUIDE. Duplicate points are allowed: the point itself stays in column 0.

    Examples
    --------
    >>> idx, dist = query_knn([[0, 0, 0], [1, 0, 0], [-1, 0, 0]], 2)
    >>> idx[0].tolist(), dist[0].tolist()
    ([0, 1], [0.0, 1.0])
    """
    return NeighborIndex(points).knn(k)


def query_radius(points, radius: float) -> RadiusNeighbors:
    """All points within ``radius`` of every point (closed ball, itself first).

    Parameters
    ----------
    points : array_like of shape (N, 3)
        Coordinates.
    radius : float
        Ball radius in the input's units.

    Returns
    -------
    neighbors : RadiusNeighbors
        CSR-style neighbourhoods.

    Notes
    -----
    Geometric neighbourhood of thesis Example 1 (iv).

    Examples
    --------
    >>> nb = query_radius([[0, 0, 0], [1, 0, 0], [3, 0, 0]], 1.0)
    >>> nb.counts.tolist(), nb.row(1).tolist()
    ([2, 2, 1], [1, 0])
    """
    return NeighborIndex(points).radius(radius)
