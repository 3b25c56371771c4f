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
(default) runs the grid and hands the few queries it cannot certify within 8
cell rings (isolated outliers far from the bulk) to an exact scan of all points
(a few) or the k-d tree; ``"grid"`` does the same after 16 rings.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from .._core import as_float, as_k, as_points, readonly
from .._core._threads import run_chunks
from .._core.tolerances import RADIUS_QUERY_WIDEN
from . import _kernels as K
from ._grid import (
    column_index,
    grid_too_coarse,
    group_queries,
    knn_grid_for,
    knn_target,
    radius_grid_for,
)

__all__ = ["NeighborIndex", "RadiusNeighbors", "query_knn", "query_radius"]

_BACKENDS = ("auto", "grid", "kdtree")

#: Rings of cells the grid kernel searches at most before handing a query to the far
#: path (`NeighborIndex._knn_far`); after 5 rings it hands over the queries these rings
#: cannot certify (far outliers). Measured in docs/decisions/neighbors.md.
_MAX_RING = {"auto": 8, "grid": 16}

#: Queries left by the grid up to which a scan of all points answers them (beyond, the
#: k-d tree; its build over N points costs about as much as this many scans).
_BRUTE_ROWS = 64

#: ``"auto"`` answers every query from the k-d tree when the grid's point-weighted
#: occupancy, counting each distinct position once, stays above this many times its
#: target (`grid_too_coarse`): the cell size cannot shrink further (int64 cell keys
#: over a box of extreme extent: a dense cluster with far outliers) and the block
#: search would scan the cluster for every query. Exact duplicates stay on the grid,
#: which handles them well (the k-d tree holds each position once, also fine).
_AUTO_TREE_OCCUPANCY = 32.0

#: Candidate entries per k-d tree query chunk (bounds temporary memory).
_CHUNK_ENTRIES = 1 << 22


def _check_rows(rows, n: int) -> np.ndarray:
    """``rows`` as a 1-D int64 array of point indices in [0, n)."""
    arr = np.asarray(rows)
    if arr.dtype == np.bool_ or not (np.issubdtype(arr.dtype, np.integer) or arr.size == 0):
        raise TypeError(f"rows must be an array of integer indices; got dtype {arr.dtype}")
    if arr.ndim != 1:
        raise ValueError(f"rows must be one-dimensional; got shape {arr.shape}")
    arr = arr.astype(np.int64)
    if arr.size and (arr.min() < 0 or arr.max() >= n):
        bad = arr[(arr < 0) | (arr >= n)]
        raise ValueError(f"rows must be indices in [0, {n}); got {bad.size} outside, e.g. {bad[0]}")
    return arr


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
        exact re-selection; ``"auto"`` (default): the grid with 8 rings. Queries
        the grid cannot certify within its rings (far outliers) are answered by a
        scan of all points (a few) or the k-d tree path. All give identical results.
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
        self._entries = None

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

    def _tree_entries(self) -> tuple[cKDTree, np.ndarray, np.ndarray]:
        """The k-NN's k-d tree over the distinct positions and, per entry, its points
        (CSR ``gptr``, ``gmem``; increasing index within an entry). Without exact
        duplicates this is `tree_` with one point per entry."""
        if self._entries is None:
            pts = self.points_
            n = pts.shape[0]
            order = np.lexsort((pts[:, 2], pts[:, 1], pts[:, 0]))  # stable: by index within
            srt = pts[order]
            new = np.ones(n, dtype=np.bool_)
            new[1:] = (srt[1:] != srt[:-1]).any(axis=1)
            if new.all():
                one = np.arange(n + 1, dtype=np.int64)
                self._entries = (self.tree_, one, one[:n])
            else:
                gptr = np.append(np.flatnonzero(new), n).astype(np.int64)
                tree = cKDTree(srt[new], balanced_tree=False, compact_nodes=False)
                self._entries = (tree, gptr, order.astype(np.int64))
        return self._entries

    def knn(self, k: int, *, rows=None) -> tuple[np.ndarray, np.ndarray]:
        """k nearest neighbours of every indexed point (or of ``rows``), itself first.

        Parameters
        ----------
        k : int
            Neighbourhood size including the point itself (1 <= k <= N).
        rows : array_like of int, optional
            Indices of the points to query (any order, repeats allowed). Row r of
            the result is then row ``rows[r]`` of the full query, bit for bit, at a
            cost proportional to ``len(rows)`` (plus the grid's build).

        Returns
        -------
        indices : ndarray of shape (N, k) or (len(rows), k), int64
            Column 0 is the point itself; the rest by (distance, index).
        distances : ndarray of shape (N, k) or (len(rows), k), float64
            Euclidean distances, non-decreasing along each row.

        Raises
        ------
        PointAtlasError
            k outside [1, N] (a ``ValueError``).
        TypeError
            k not an integer (bool and floats included); ``rows`` not integers.
        ValueError
            ``rows`` not one-dimensional or outside [0, N).
        """
        n = self.n_points
        k = as_k(k, n)
        queries = None if rows is None else _check_rows(rows, n)
        n_out = n if queries is None else queries.size
        if k == 1:
            self_col = np.arange(n, dtype=np.int64) if queries is None else queries.copy()
            return self_col[:, None], np.zeros((n_out, 1))
        if self.backend == "kdtree":
            all_rows = np.arange(n, dtype=np.int64) if queries is None else queries
            out_idx, out_d2 = self._knn_kdtree(all_rows, k)
        else:
            out_idx, out_d2 = self._knn_grid(k, queries)
        K.sqrt_inplace(out_d2)
        return out_idx, out_d2

    def _knn_grid(self, k: int, queries) -> tuple[np.ndarray, np.ndarray]:
        """k-NN rows (squared distances) of all points (``queries`` None) or of the
        given point indices, on the grid; the rows it cannot certify within its rings
        from the k-d tree path."""
        grid = knn_grid_for(self.points_, k)
        if self.backend == "auto" and grid_too_coarse(grid, _AUTO_TREE_OCCUPANCY * knn_target(k)):
            rows = np.arange(self.n_points, dtype=np.int64) if queries is None else queries
            return self._knn_kdtree(rows, k)
        if queries is None:
            qcells = np.arange(grid.ukeys.size, dtype=np.int64)
            qstart, qpos, qout = grid.cstart, np.arange(grid.ids.size, dtype=np.int64), grid.ids
            n_out = grid.ids.size
        else:
            qcells, qstart, qpos, qout = group_queries(grid, queries)
            n_out = queries.size
        out_idx = np.empty((n_out, k), dtype=np.int64)
        out_d2 = np.empty((n_out, k), dtype=np.float64)
        failed = np.zeros(n_out, dtype=np.bool_)
        cells = (grid.xs, grid.ys, grid.zs, grid.ids, grid.ukeys, grid.cstart)
        cells += (column_index(grid), grid.lo, grid.h, grid.nx, grid.ny, grid.nz)
        grouped = (qcells, qstart, qpos, qout)
        # the block of each query's cell, then the rows it left (`_kernels.knn_rings`)
        state = np.zeros(qpos.size, dtype=np.uint8)
        run_chunks(K.knn_grid, qcells.size, (cells, grouped, (out_idx, out_d2, state), k))
        slots = np.flatnonzero(state)
        if slots.size:
            of_slot = np.searchsorted(qstart, slots, side="right") - 1
            outputs = (out_idx, out_d2, failed)
            pending = (slots, of_slot, state)
            args = (cells, grouped, outputs, k, _MAX_RING[self.backend], pending)
            run_chunks(K.knn_grid_rings, slots.size, args)
        bad = np.flatnonzero(failed)
        if bad.size:
            point = bad if queries is None else queries[bad]
            out_idx[bad], out_d2[bad] = self._knn_far(point, k)
        return out_idx, out_d2

    def _knn_far(self, rows: np.ndarray, k: int) -> tuple[np.ndarray, np.ndarray]:
        """Exact k-NN rows (squared distances) of the queries the grid left: a scan of
        all points for a few of them, else the k-d tree path (its build costs about as
        much as `_BRUTE_ROWS` scans)."""
        if self._tree is not None or rows.size > _BRUTE_ROWS:
            return self._knn_kdtree(rows, k)
        out_idx = np.empty((rows.size, k), dtype=np.int64)
        out_d2 = np.empty((rows.size, k), dtype=np.float64)
        K.knn_brute(self.points_, rows, k, out_idx, out_d2)
        return out_idx, out_d2

    def _knn_kdtree(self, rows: np.ndarray, k: int) -> tuple[np.ndarray, np.ndarray]:
        """Exact k-NN rows (squared distances) of ``rows`` from the k-d tree.

        Queries k + 1 candidates, re-selects them exactly by (d2, index) and
        doubles the candidate count for the rows whose k-th neighbour ties with
        the first point left out (grids) until no tie is possible. Exact
        duplicates share one tree entry (`_tree_entries`), so a cluster of them
        costs k candidates per query rather than its size.
        """
        pts = self.points_
        tree, gptr, gmem = self._tree_entries()
        n_entries = gptr.size - 1
        out_idx = np.empty((rows.size, k), dtype=np.int64)
        out_d2 = np.empty((rows.size, k), dtype=np.float64)
        pending = np.arange(rows.size, dtype=np.int64)
        kk = min(k + 1, n_entries)
        while pending.size:
            all_points = kk >= n_entries
            chunk = max(1, _CHUNK_ENTRIES // kk)
            still = []
            for s in range(0, pending.size, chunk):
                part = pending[s : s + chunk]
                q = rows[part]
                dist, cand = tree.query(pts[q], k=kk, workers=-1)
                cand = np.asarray(cand, dtype=np.int64).reshape(q.size, kk)
                last = np.asarray(dist, dtype=np.float64).reshape(q.size, kk)[:, -1] ** 2
                idx_p = np.empty((q.size, k), dtype=np.int64)
                d2_p = np.empty((q.size, k), dtype=np.float64)
                ok = np.empty(q.size, dtype=np.bool_)
                K.select_candidates(pts, q, cand, last, k, all_points, gptr, gmem, idx_p, d2_p, ok)
                out_idx[part[ok]] = idx_p[ok]
                out_d2[part[ok]] = d2_p[ok]
                still.append(part[~ok])
            pending = np.concatenate(still)
            kk = min(2 * kk, n_entries)
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
        args = (
            grid.xs,
            grid.ys,
            grid.zs,
            grid.ids,
            grid.ukeys,
            grid.cstart,
            grid.lo,
            grid.h,
            grid.nx,
            grid.ny,
            grid.nz,
            r2,
        )
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
