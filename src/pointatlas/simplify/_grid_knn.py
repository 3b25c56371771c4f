"""The k nearest of a fixed point set, exactly as scipy's k-d tree finds them
(private; numba): a grid of cells searched ring by ring, for the robust path's
many queries near the points (`GridKnn`).

The robust path asks for the nearest points of positions close to the points: the
voxel grid's band nodes (416,251 on a sampled CAD part of 20,000 points, 8 each:
`_reconstruct._field`), and each level's vertices and samples in the level search
(`_distance.PointSurface`). A k-d tree descends from its root for each query (about
1.5 microseconds a band node on one core); here each query scans the cells around
its own, one shell of cells at a time, until its k-th nearest is nearer than any
point outside the cells scanned: the band's query in 0.27 s instead of 0.58 s on
two cores, the same arrays.

Exactly the answer of ``cKDTree(points).query(x, k)``: squared distances summed as
scipy's k-d tree sums them (``((0 + dx^2) + dy^2) + dz^2``), then their square roots,
nearest first; only the order of equally distant points (exact duplicates) is
defined here (the smaller index first) where the tree's is not. Not
`neighbors.NeighborIndex`: its distances are taken on centred coordinates (other
last bits than the tree's, which every output of the robust path was measured
with) and it answers the points' own neighbourhoods.
"""

from __future__ import annotations

import numpy as np
from numba import njit
from scipy.spatial import cKDTree

from .._core._threads import query_workers, run_chunks

__all__ = ["GridKnn"]

#: At most this many cells per point (a sparse set in a large box: the cells grow).
_CELLS_PER_POINT = 8

#: A point within this share of a cell of the cells' boundary may have been binned
#: on either side of it (floating-point rounding): the search's bound keeps that far
#: from the boundary, and at least 8 units in the last place of the coordinates'
#: magnitude (cells far from the origin: their bounds are rounded to those units).
_MARGIN = 1e-6


class GridKnn:
    """The ``points`` (n, 3) in cells of side ``cell`` (or larger: at most
    `_CELLS_PER_POINT` cells per point, 2^20 in all), for `query`. Callers take
    cells of about 3 point spacings: a query's 6 to 16 nearest points then lie
    within one or two rings of cells (the band's query with cells of 1.5 spacings
    0.53 s, of 4.5 spacings 0.25 s, of 3 spacings 0.27 s). Where the cells would
    have to grow past twice ``cell`` (a few points far from the rest: most points
    in a few cells, each query scanning them all), `query` asks a k-d tree instead
    (the same answers but the order of exact duplicates).

    Examples
    --------
    >>> p = np.array([[0.2, 0.1, 0.0], [1.7, 0.3, 0.2], [0.9, 0.9, 0.9]])
    >>> d, j = GridKnn(p, 1.0).query(np.array([[0.0, 0, 0], [2.0, 0, 0]]), 2)
    >>> j.tolist(), d[:, 0].round(3).tolist()
    ([[0, 2], [1, 2]], [0.224, 0.469])
    """

    def __init__(self, points, cell: float):
        q = np.ascontiguousarray(points, dtype=np.float64)
        self.n = q.shape[0]
        self.corner = q.min(axis=0) if self.n else np.zeros(3)
        extent = (q.max(axis=0) - self.corner) if self.n else np.zeros(3)
        h = asked = float(cell) if cell > 0.0 else max(float(extent.max()), 1.0)
        limit = max(_CELLS_PER_POINT * self.n, 1 << 20)
        while np.prod(np.floor(extent / h) + 1.0) > limit:
            h *= 1.25
        self.h = h
        self.tree = cKDTree(q) if h > 2.0 * asked else None
        if self.tree is not None:  # `query` asks the tree: no cells
            return
        size = float(np.abs(self.corner).max() + extent.max())
        self.margin = _MARGIN * h + 8.0 * np.finfo(np.float64).eps * size
        at = np.floor((q - self.corner) / h).astype(np.int64)
        self.dims = (at.max(axis=0) + 1) if self.n else np.ones(3, dtype=np.int64)
        key = (at[:, 0] * self.dims[1] + at[:, 1]) * self.dims[2] + at[:, 2]
        self.ids = np.argsort(key, kind="stable").astype(np.int64)
        cells = np.arange(int(np.prod(self.dims)) + 1)
        self.start = np.searchsorted(key[self.ids], cells).astype(np.int64)
        self.sorted = np.ascontiguousarray(q[self.ids])
        self._empty_steps = None  # `farther_than`'s: each cell's to one with a point

    def query(self, x, k: int):
        """``(d, j)``: each row of ``x``'s ``k`` nearest points (1 <= k <= n), their
        distances (m, k) ascending and indices (m, k) int64, as
        ``cKDTree(points).query(x, k)`` gives them (ties: the smaller index first)."""
        x = np.ascontiguousarray(x, dtype=np.float64).reshape(-1, 3)
        if self.tree is not None:
            d, j = self.tree.query(x, k=k, workers=query_workers(x.shape[0], k))
            return d.reshape(x.shape[0], k), j.reshape(x.shape[0], k).astype(np.int64)
        home = np.floor((x - self.corner) / self.h)
        home = np.clip(home, 0, self.dims - 1).astype(np.int64)  # outside: the nearest
        d = np.empty((x.shape[0], k))
        j = np.empty((x.shape[0], k), dtype=np.int64)
        grid = (self.sorted, self.ids, self.start, self.dims, self.corner, self.h, self.margin)
        run_chunks(_knn_rows, x.shape[0], (x, home, *grid, d, j), min_piece=512)
        return d, j

    def nearest_of(self, x, rows):
        """``(d, j)``: the nearest point of each of ``x``'s ``rows`` (a mask or
        indices) and its distance (`query`); inf and 0 for the other rows."""
        x = np.ascontiguousarray(x, dtype=np.float64).reshape(-1, 3)
        rows = np.flatnonzero(rows) if np.asarray(rows).dtype == bool else np.asarray(rows)
        d, j = np.full(x.shape[0], np.inf), np.zeros(x.shape[0], dtype=np.int64)
        if rows.size:
            d[rows], j[rows] = (a[:, 0] for a in self.query(x[rows], 1))
        return d, j

    def farther_than(self, x, dist: float) -> np.ndarray:
        """Which rows of ``x`` are surely farther than ``dist`` from every point, told
        by the cells alone: a row whose own cell is D cells (Chebyshev) from every
        cell with a point is at least (D - 1) cell sides from the points (a row
        outside the cells: D the larger of its nearest cell's and its own offset).
        For the queries `query` would answer slowly (its shells grow as the cube of
        D: a one-view scan's voxel surface, 623,160 triangles a median 13 cells from
        the points, 31.5 s for their nearest points); all False where a k-d tree
        answers."""
        from scipy.ndimage import distance_transform_cdt

        x = np.ascontiguousarray(x, dtype=np.float64).reshape(-1, 3)
        if self.tree is not None:
            return np.zeros(x.shape[0], dtype=bool)
        if self._empty_steps is None:  # each cell's distance to one with a point
            taken = (self.start[1:] > self.start[:-1]).reshape(tuple(self.dims))
            self._empty_steps = distance_transform_cdt(~taken, metric="chessboard").ravel()
        cells = np.floor((x - self.corner) / self.h)
        home = np.clip(cells, 0, self.dims - 1).astype(np.int64)
        key = (home[:, 0] * self.dims[1] + home[:, 1]) * self.dims[2] + home[:, 2]
        steps = np.maximum(self._empty_steps[key], np.abs(cells - home).max(axis=1))
        return (steps - 1.0) * self.h - self.margin > dist


@njit(cache=True)
def _offer(bd, bi, d2, i) -> None:
    """Point ``i`` at squared distance ``d2`` into the sorted buffers (by d2, then
    i), where it comes before their last entry (`_scan` checks)."""
    m = bd.shape[0] - 1
    while m > 0 and (d2 < bd[m - 1] or (d2 == bd[m - 1] and i < bi[m - 1])):
        bd[m] = bd[m - 1]
        bi[m] = bi[m - 1]
        m -= 1
    bd[m] = d2
    bi[m] = i


@njit(cache=True, inline="always")
def _scan(q, ids, a, b, x0, x1, x2, bd, bi) -> None:
    """Offer the sorted points ``a`` to ``b`` (scipy's k-d tree's sum of squares);
    most are farther than the k-th so far, checked here (a call per point, its
    arrays' reference counts, took ten times as long)."""
    last = bd.shape[0] - 1
    for t in range(a, b):
        e = q[t, 0] - x0
        s = 0.0 + e * e
        e = q[t, 1] - x1
        s += e * e
        e = q[t, 2] - x2
        s += e * e
        if s < bd[last] or (s == bd[last] and ids[t] < bi[last]):
            _offer(bd, bi, s, ids[t])


@njit(cache=True, inline="always")
def _clearance(x, c, r, n, corner, h) -> float:
    """How far ``x`` is, along one axis, from the points outside cells c - r to c + r
    (infinite on a side with no cells beyond)."""
    out = np.inf
    if c - r > 0:
        out = x - (corner + (c - r) * h)
    if c + r < n - 1:
        out = min(out, corner + (c + r + 1) * h - x)
    return out


@njit(cache=True, inline="always")
def _gap(x, a, b, corner, h, margin) -> float:
    """A lower bound of the squared distance, along one axis, from ``x`` to the
    points binned in cells ``a`` to ``b`` (their span less ``margin`` on each side,
    so that a point rounded into a neighbouring cell is not missed)."""
    out = max(corner + a * h - x, x - (corner + (b + 1) * h)) - margin
    return out * out if out > 0.0 else 0.0


@njit(cache=True, nogil=True)
def _knn_rows(x, home, q, ids, start, dims, corner, h, margin, out_d, out_j, i0, i1) -> None:
    """`GridKnn.query` for the rows ``i0`` to ``i1``: around each row's own cell, the
    cells at Chebyshev distance r = 0, 1, 2, ... (a column of cells along the last
    axis is one run of the sorted points: the whole column on the shell's sides, its
    two ends inside them) until its k-th nearest is within the clearance of the
    cells scanned (a row outside the cells has the nearest cell as its own: the
    clearance counts only the sides with cells beyond). One kernel, without calls
    per cell (a call with its arrays' reference counts per column took twice as
    long), and one place that scans a run of cells: the column and its two ends
    written as three inlined scans took 3-4x as long (the band of `cad_a_a38`). A
    column or cell farther than the k-th nearest so far (`_gap`) is not scanned: the
    queries of three sampled models' runs in 1.24 s instead of 1.42 s, the same
    arrays."""
    k = out_d.shape[1]
    last = k - 1
    bd = np.empty(k)
    bi = np.empty(k, dtype=np.int64)
    n0, n1, n2 = dims[0], dims[1], dims[2]
    for i in range(i0, i1):
        bd[:] = np.inf
        bi[:] = np.iinfo(np.int64).max
        c0, c1, c2 = home[i, 0], home[i, 1], home[i, 2]
        x0, x1, x2 = x[i, 0], x[i, 1], x[i, 2]
        r = 0
        while True:
            z0, z1 = max(c2 - r, 0), min(c2 + r, n2 - 1)
            for a in range(max(c0 - r, 0), min(c0 + r, n0 - 1) + 1):
                g0 = _gap(x0, a, a, corner[0], h, margin)
                for b in range(max(c1 - r, 0), min(c1 + r, n1 - 1) + 1):
                    g01 = g0 + _gap(x1, b, b, corner[1], h, margin)
                    if g01 > bd[last]:  # the column is farther than the k-th so far
                        continue
                    row = (a * n1 + b) * n2
                    side = abs(a - c0) == r or abs(b - c1) == r
                    for end in range(2):
                        if side:  # the whole column, once
                            if end == 1:
                                break
                            za, zb = z0, z1
                        else:  # its two ends (one when r = 0)
                            za = zb = c2 - r if end == 0 else c2 + r
                            if za < 0 or za >= n2 or (end == 1 and r == 0):
                                continue
                        if g01 + _gap(x2, za, zb, corner[2], h, margin) > bd[last]:
                            continue
                        lo, hi = row + za, row + zb + 1
                        _scan(q, ids, start[lo], start[hi], x0, x1, x2, bd, bi)
            g = _clearance(x0, c0, r, n0, corner[0], h)
            g = min(g, _clearance(x1, c1, r, n1, corner[1], h))
            g = min(g, _clearance(x2, c2, r, n2, corner[2], h))
            if g == np.inf:  # every cell scanned
                break
            g -= margin
            if g > 0.0 and bd[last] <= g * g:
                break
            r += 1
        for m in range(k):
            out_d[i, m] = np.sqrt(bd[m])
            out_j[i, m] = bi[m]
