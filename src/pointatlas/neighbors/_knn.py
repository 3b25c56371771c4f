"""k-nearest and radius neighbourhoods with a deterministic tie-break.

Combinatorial neighbourhood (thesis Example 1 v): the k nearest
points *including the point itself*. Decision (docs/decisions/neighbors.md): column 0 is
always the point itself, even when exact duplicates with smaller indices exist;
the other k - 1 columns are the remaining points ordered by (squared distance,
index), so among equally distant candidates the smaller index wins and N^c is
unique. Squared distances are evaluated as ``dx*dx + dy*dy + dz*dz`` in float64 on
coordinates centred on their bounding-box centre; exact equality is a tie.

Two backends give identical results (tested): ``"grid"``, a numba kernel on a
compact sorted-cell grid (``_grid.py``, ``_kernels.py``), and ``"kdtree"``, scipy's
``cKDTree`` followed by an exact numba re-selection of its candidates. ``"auto"``
(default) runs the grid and hands the few queries it cannot certify within 3
cell rings (isolated outliers far from the bulk) to the k-d tree; ``"grid"`` does
the same after 16 rings.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from .._core import as_float, as_k, as_points, readonly
from .._core.tolerances import RADIUS_QUERY_WIDEN
from . import _kernels as K
from ._grid import knn_grid_for, radius_grid_for

__all__ = ["NeighborIndex", "RadiusNeighbors", "query_knn", "query_radius"]

_BACKENDS = ("auto", "grid", "kdtree")

#: Rings of cells the grid kernel searches before handing a query to the k-d tree
#: (backend "auto"; "grid" searches further, bounding the cost of a far outlier).
_MAX_RING = {"auto": 3, "grid": 16}

#: Candidate entries per k-d tree query chunk (bounds temporary memory).
_CHUNK_ENTRIES = 1 << 22


def _check_backend(backend) -> str:
    if backend not in _BACKENDS:
        raise ValueError(f"backend must be one of {_BACKENDS}; got {backend!r}")
    return backend


class NeighborIndex:
    """A spatial index over a point set, built once and queried many times.

    Parameters
    ----------
    points : array_like of shape (N, 3)
        Coordinates (validated; non-finite values raise).
    backend : {"auto", "grid", "kdtree"}
        ``"grid"``: numba kernel on a compact sorted-cell grid, searching up to
        16 rings of cells around a query; ``"kdtree"``: scipy ``cKDTree`` plus an
        exact re-selection; ``"auto"`` (default): the grid with 3 rings. Queries
        the grid cannot certify within its rings (far outliers) are answered by
        the k-d tree path. All give identical results.
    center : array_like of shape (3,), optional
        The point subtracted from every coordinate (default: the centre of the
        bounding box). An index over part of a point set built with the centre of
        the whole set computes the whole set's squared distances bit for bit (the
        tiles of `pointatlas.batch`).

    Notes
    -----
    Coordinates are centred (on their bounding-box centre unless ``center`` is
    given) before anything else so distances keep their precision for UTM-like
    inputs (a shift by 1e6 gives the same neighbours). Exact ties of the squared
    distance are broken by smaller index (docs/decisions/neighbors.md). The one-shot
    functions `query_knn` and `query_radius` wrap this class. Grids depend on k (or
    the radius) and are built per query; the k-d tree is built lazily once.

    Examples
    --------
    >>> idx = NeighborIndex([[0, 0, 0], [1, 0, 0], [3, 0, 0]])
    >>> idx.knn(2)[0].tolist()
    [[0, 1], [1, 0], [2, 1]]
    """

    def __init__(self, points, *, backend: str = "auto", center=None):
        pts = as_points(points, min_points=1)
        self.backend = _check_backend(backend)
        if center is None:
            lo, hi = K.bounds(pts)
            self.center_ = 0.5 * (lo + hi)
        else:
            self.center_ = np.array(center, dtype=np.float64)
            if self.center_.shape != (3,) or not np.isfinite(self.center_).all():
                raise ValueError(f"center must be 3 finite numbers; got {center!r}")
        self.points_ = readonly(pts - self.center_)
        self._tree = None

    @property
    def n_points(self) -> int:
        """Number of indexed points."""
        return int(self.points_.shape[0])

    @property
    def tree_(self) -> cKDTree:
        """The scipy ``cKDTree`` over the centred points (built on first use)."""
        if self._tree is None:
            self._tree = cKDTree(self.points_, balanced_tree=False, compact_nodes=False)
        return self._tree

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
            k outside [1, N] (a ``ValueError``).
        TypeError
            k not an integer (bool and floats included).
        """
        n = self.n_points
        k = as_k(k, n)
        if k == 1:
            return np.arange(n, dtype=np.int64)[:, None], np.zeros((n, 1))
        if self.backend == "kdtree":
            out_idx, out_d2 = self._knn_kdtree(np.arange(n, dtype=np.int64), k)
        else:
            grid = knn_grid_for(self.points_, k)
            out_idx = np.empty((n, k), dtype=np.int64)
            out_d2 = np.empty((n, k), dtype=np.float64)
            failed = np.zeros(n, dtype=np.bool_)
            max_ring = _MAX_RING[self.backend]
            K.knn_grid(
                grid.xs, grid.ys, grid.zs, grid.ids, grid.ukeys, grid.cstart, grid.lo,
                grid.h, grid.nx, grid.ny, grid.nz, k, max_ring, out_idx, out_d2, failed,
            )  # fmt: skip
            rows = np.flatnonzero(failed)
            if rows.size:
                out_idx[rows], out_d2[rows] = self._knn_kdtree(rows, k)
        K.sqrt_inplace(out_d2)
        return out_idx, out_d2

    def _knn_kdtree(self, rows: np.ndarray, k: int) -> tuple[np.ndarray, np.ndarray]:
        """Exact k-NN rows (squared distances) of ``rows`` from the k-d tree.

        Queries k + 1 candidates, re-selects them exactly by (d2, index) and
        doubles the candidate count for the rows whose k-th neighbour ties with
        the first point left out (grids, duplicates) until no tie is possible.
        """
        n = self.n_points
        pts = self.points_
        out_idx = np.empty((rows.size, k), dtype=np.int64)
        out_d2 = np.empty((rows.size, k), dtype=np.float64)
        pending = np.arange(rows.size, dtype=np.int64)
        kk = min(k + 1, n)
        while pending.size:
            all_points = kk >= n
            chunk = max(1, _CHUNK_ENTRIES // kk)
            still = []
            for s in range(0, pending.size, chunk):
                part = pending[s : s + chunk]
                q = rows[part]
                dist, cand = self.tree_.query(pts[q], k=kk, workers=-1)
                cand = np.asarray(cand, dtype=np.int64).reshape(q.size, kk)
                last = np.asarray(dist, dtype=np.float64).reshape(q.size, kk)[:, -1] ** 2
                idx_p = np.empty((q.size, k), dtype=np.int64)
                d2_p = np.empty((q.size, k), dtype=np.float64)
                ok = np.empty(q.size, dtype=np.bool_)
                K.select_candidates(pts, q, cand, last, k, all_points, idx_p, d2_p, ok)
                out_idx[part[ok]] = idx_p[ok]
                out_d2[part[ok]] = d2_p[ok]
                still.append(part[~ok])
            pending = np.concatenate(still)
            kk = min(2 * kk, n)
        return out_idx, out_d2

    def radius(self, radius: float) -> RadiusNeighbors:
        """All points within ``radius`` (closed ball) of every indexed point.

        Parameters
        ----------
        radius : float
            Ball radius in the input's units (> 0). A point is inside when its
            squared distance is <= ``radius**2`` (float64).

        Returns
        -------
        neighbors : RadiusNeighbors
            CSR-style arrays; each row starts with the point itself, then by
            (distance, index).

        Raises
        ------
        ValueError
            Non-positive or non-finite radius.
        TypeError
            Non-numeric radius (bool included).
        """
        radius = as_float(radius, "radius", lo=0.0, lo_open=True)
        if self.backend == "kdtree":
            return self._radius_kdtree(radius)
        n = self.n_points
        grid = radius_grid_for(self.points_, radius)
        r2 = radius * radius
        counts = np.zeros(n, dtype=np.int64)
        dummy_i = np.empty(0, dtype=np.int64)
        dummy_d = np.empty(0, dtype=np.float64)
        args = (grid.xs, grid.ys, grid.zs, grid.ids, grid.ukeys, grid.cstart, grid.lo, grid.h,
                grid.nx, grid.ny, grid.nz, r2)  # fmt: skip
        K.radius_grid(*args, counts, dummy_i, dummy_i, dummy_d, False)
        indptr = np.zeros(n + 1, dtype=np.int64)
        np.cumsum(counts, out=indptr[1:])
        indices = np.empty(indptr[-1], dtype=np.int64)
        d2 = np.empty(indptr[-1], dtype=np.float64)
        K.radius_grid(*args, counts, indptr, indices, d2, True)
        return RadiusNeighbors(indptr=indptr, indices=indices, distances=np.sqrt(d2, out=d2))

    def _radius_kdtree(self, radius: float) -> RadiusNeighbors:
        n = self.n_points
        pts = self.points_
        pairs = self.tree_.sparse_distance_matrix(
            self.tree_, radius * (1.0 + RADIUS_QUERY_WIDEN), output_type="ndarray"
        )
        i = np.asarray(pairs["i"], dtype=np.int64)
        j = np.asarray(pairs["j"], dtype=np.int64)
        d = pts[j] - pts[i]
        d2 = d[:, 0] * d[:, 0] + d[:, 1] * d[:, 1] + d[:, 2] * d[:, 2]
        keep = (d2 <= radius * radius) & (i != j)
        i, j, d2 = i[keep], j[keep], d2[keep]
        self_rows = np.arange(n, dtype=np.int64)
        i = np.concatenate([self_rows, i])
        j = np.concatenate([self_rows, j])
        d2 = np.concatenate([np.zeros(n), d2])
        order = np.argsort(i, kind="stable")
        i, j, d2 = i[order], j[order], d2[order]
        indptr = np.zeros(n + 1, dtype=np.int64)
        np.cumsum(np.bincount(i, minlength=n), out=indptr[1:])
        K.sort_rows(indptr, j, d2)
        return RadiusNeighbors(indptr=indptr, indices=j, distances=np.sqrt(d2))


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


def query_knn(points, k: int, *, backend: str = "auto") -> tuple[np.ndarray, np.ndarray]:
    """k nearest neighbours of every point, the point itself included and first.

    Parameters
    ----------
    points : array_like of shape (N, 3)
        Coordinates.
    k : int
        Neighbourhood size including the point itself (1 <= k <= N).
    backend : {"auto", "grid", "kdtree"}
        Search structure (see `NeighborIndex`); results are identical.

    Returns
    -------
    indices : ndarray of shape (N, k), int64
        Column 0 is the point itself; then by (distance, smaller index first).
    distances : ndarray of shape (N, k), float64
        Euclidean distances.

    Raises
    ------
    ValueError
        Non-finite or badly shaped points, unknown backend; k outside [1, N]
        (a `PointAtlasError`: "k must be an integer in [1, N] (the number of
        points); got ...").
    TypeError
        Non-integer k (bool and floats included).

    Notes
    -----
    Combinatorial neighbourhood of thesis Example 1 (v) with the tie-break
    recorded in docs/decisions/neighbors.md. Duplicate points are allowed: the
    point itself stays in column 0 and its duplicates follow by index. Ties are
    exact float64 equality of squared distances on bounding-box-centred
    coordinates.

    Examples
    --------
    >>> idx, dist = query_knn([[0, 0, 0], [1, 0, 0], [-1, 0, 0]], 2)
    >>> idx[0].tolist(), dist[0].tolist()
    ([0, 1], [0.0, 1.0])
    """
    return NeighborIndex(points, backend=backend).knn(k)


def query_radius(points, radius: float, *, backend: str = "auto") -> RadiusNeighbors:
    """All points within ``radius`` of every point (closed ball, itself first).

    Parameters
    ----------
    points : array_like of shape (N, 3)
        Coordinates.
    radius : float
        Ball radius in the input's units; inside means squared distance
        <= ``radius**2``.
    backend : {"auto", "grid", "kdtree"}
        ``"auto"`` and ``"grid"`` use a grid of cells of size ``radius``;
        ``"kdtree"`` uses scipy's ``cKDTree``. Results are identical.

    Returns
    -------
    neighbors : RadiusNeighbors
        CSR-style neighbourhoods: itself first, then by (distance, index).

    Raises
    ------
    ValueError
        Non-finite or badly shaped points; non-positive or non-finite radius.
    TypeError
        Non-numeric radius.

    Notes
    -----
    Geometric neighbourhood of thesis Example 1 (iv).

    Examples
    --------
    >>> nb = query_radius([[0, 0, 0], [1, 0, 0], [3, 0, 0]], 1.0)
    >>> nb.counts.tolist(), nb.row(1).tolist()
    ([2, 2, 1], [1, 0])
    """
    return NeighborIndex(points, backend=backend).radius(radius)
