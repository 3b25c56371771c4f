"""The sorted-cell grid of the neighbour queries (numba kernels; docs/decisions/neighbors.md).

All kernels assume validated input: finite float64 coordinates that are already
centred (``_knn.NeighborIndex``), int64 indices, and the sorted-cell grid built by
``_grid.build_grid``. Nothing here allocates per point in Python.

Ordering convention shared by every kernel: a neighbour j of query q is keyed by
``(d2, j)`` where ``d2 = dx*dx + dy*dy + dz*dz`` is the squared distance in
float64 (evaluated in exactly this order), so exact ties are broken by the smaller
index. Column 0 of a k-NN row is always the query itself.

The grid is a *compact* sorted-cell array: points are ordered by the int64 key
``(i * ny + j) * nz + kz`` of their cell (stable, so equal keys keep index order),
``ukeys`` lists the occupied keys and ``cstart`` their point ranges. A run of cells
along z with fixed (i, j) is contiguous in that order, so a 3 x 3 x 3 block is read
as nine contiguous ranges found by binary search; no dense 3-D array exists.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from ..._core.kernels import bounds

__all__ = [
    "bounds",
    "cell_coords",
    "cells_in_column",
    "chunk_cells",
    "column_range",
    "group_by_cell",
    "interleaved_chunks",
    "lower_bound",
    "occupancy_levels",
    "sq_dist",
]


@njit(cache=True)
def occupancy_levels(xs, ys, zs, ukeys, cstart, lo, h, ny, nz):
    """Point-weighted occupancy sums at cell sizes h, h/2 and h/4.

    Returns ``sum over cells of n_c**2`` for the three levels, where a cell whose
    points all coincide counts ``n_c`` instead (exact duplicates are answered in
    O(k) per query by the k-NN kernel, so they must not shrink the cells).
    """
    n_cells = ukeys.shape[0]
    s0 = 0.0
    s1 = 0.0
    s2 = 0.0
    inv_q = 4.0 / h
    cnt = np.empty(64, dtype=np.int64)
    same = np.empty(64, dtype=np.bool_)
    fx = np.empty(64)
    fy = np.empty(64)
    fz = np.empty(64)
    for c in range(n_cells):
        for s in range(64):
            cnt[s] = 0
            same[s] = True
        key = ukeys[c]
        kz = key % nz
        t = key // nz
        j = t % ny
        i = t // ny
        for p in range(cstart[c], cstart[c + 1]):
            si = min(max(np.int64(np.floor((xs[p] - lo[0]) * inv_q)) - 4 * i, 0), 3)
            sj = min(max(np.int64(np.floor((ys[p] - lo[1]) * inv_q)) - 4 * j, 0), 3)
            sk = min(max(np.int64(np.floor((zs[p] - lo[2]) * inv_q)) - 4 * kz, 0), 3)
            s = (si * 4 + sj) * 4 + sk
            if cnt[s] == 0:
                fx[s] = xs[p]
                fy[s] = ys[p]
                fz[s] = zs[p]
            elif xs[p] != fx[s] or ys[p] != fy[s] or zs[p] != fz[s]:
                same[s] = False
            cnt[s] += 1
        a2 = 0.0
        for s in range(64):
            m = cnt[s]
            a2 += m if same[s] else m * m
        a1 = 0.0
        n_nonempty_all = 0
        last_all = -1
        for g in range(8):
            gi = g >> 2
            gj = (g >> 1) & 1
            gk = g & 1
            m = 0
            n_nonempty = 0
            last = -1
            for d in range(8):
                s = ((2 * gi + (d >> 2)) * 4 + 2 * gj + ((d >> 1) & 1)) * 4 + 2 * gk + (d & 1)
                if cnt[s] > 0:
                    m += cnt[s]
                    n_nonempty += 1
                    last = s
                    n_nonempty_all += 1
                    last_all = s
            if n_nonempty == 1 and same[last]:
                a1 += m
            else:
                a1 += m * m
        m = cstart[c + 1] - cstart[c]
        if n_nonempty_all == 1 and same[last_all]:
            a0 = 1.0 * m
        else:
            a0 = 1.0 * m * m
        s0 += a0
        s1 += a1
        s2 += a2
    return s0, s1, s2


@njit(cache=True)
def _gcd(a, b):
    while b:
        a, b = b, a % b
    return a


@njit(cache=True)
def interleaved_chunks(n_cells):
    """``(n_chunks, stride)``: cells split into at most 4096 chunks, chunk
    ``(t * stride) % n_chunks`` run by parallel iteration t, so the static thread
    blocks interleave dense and sparse regions (load balance)."""
    n_chunks = min(n_cells, 4096)
    stride = 2654435761 % n_chunks if n_chunks > 1 else 1
    while n_chunks > 1 and _gcd(stride, n_chunks) != 1:
        stride += 1
    return n_chunks, stride


@njit(cache=True)
def chunk_cells(t, stride, n_chunks, n_cells):
    """Cells ``c0 .. c1 - 1`` of parallel iteration t (chunk ``(t * stride) % n_chunks``
    of `interleaved_chunks`)."""
    chunk = (t * stride) % n_chunks
    return chunk * n_cells // n_chunks, (chunk + 1) * n_cells // n_chunks


@njit(cache=True, inline="always")
def sq_dist(xs, ys, zs, p, qx, qy, qz):
    """The squared distance d2 of grid point p from the query (qx, qy, qz), summed in
    the order of the module's ordering convention."""
    dx = xs[p] - qx
    dy = ys[p] - qy
    dz = zs[p] - qz
    return dx * dx + dy * dy + dz * dz


@njit(cache=True)
def cell_coords(key, ny, nz):
    """(i, j, k) of the cell with key ``(i * ny + j) * nz + k``."""
    ck = key % nz
    tt = key // nz
    return tt // ny, tt % ny, ck


@njit(cache=True)
def lower_bound(a, x):
    """First position in the sorted ``a`` whose value is >= x."""
    return _lower_bound_in(a, np.int64(0), a.shape[0], x)


@njit(cache=True)
def _lower_bound_in(a, lo, hi, x):
    """First position in ``lo:hi`` of the sorted ``a`` whose value is >= x."""
    while lo < hi:
        mid = (lo + hi) >> 1
        if a[mid] < x:
            lo = mid + 1
        else:
            hi = mid
    return lo


@njit(cache=True)
def cells_in_column(ukeys, colptr, i, j, z0, z1, ny, nz):
    """Positions ``ca:cb`` in ``ukeys`` of the occupied cells (i, j, z0..z1) (inclusive,
    already clipped). With a column index ``colptr`` (`_grid.column_index`) the search runs
    inside the column; with an empty ``colptr`` it bisects all cells."""
    col = i * ny + j
    base = col * nz
    if colptr.shape[0] == 0:
        return lower_bound(ukeys, base + z0), lower_bound(ukeys, base + z1 + 1)
    a = colptr[col]
    b = colptr[col + 1]
    return _lower_bound_in(ukeys, a, b, base + z0), _lower_bound_in(ukeys, a, b, base + z1 + 1)


@njit(cache=True)
def column_range(ukeys, cstart, i, j, z0, z1, ny, nz):
    """Point range of cells (i, j, z0..z1) (inclusive, already clipped)."""
    base = (i * ny + j) * nz
    a = lower_bound(ukeys, base + z0)
    b = lower_bound(ukeys, base + z1 + 1)
    return cstart[a], cstart[b]


@njit(cache=True)
def group_by_cell(ids, cstart, queries):
    """Point indices ``queries`` grouped by grid cell: ``(qcells, qstart, qpos, qout)``
    (see ``_grid.group_queries``), by a counting sort of their cell-order positions
    (stable: equal positions keep their order in ``queries``), O(N + len(queries))."""
    n = ids.shape[0]
    nq = queries.shape[0]
    pos_of = np.empty(n, dtype=np.int64)
    for p in range(n):
        pos_of[ids[p]] = p
    start = np.zeros(n + 1, dtype=np.int64)
    for r in range(nq):
        start[pos_of[queries[r]] + 1] += 1
    for p in range(n):
        start[p + 1] += start[p]
    qpos = np.empty(nq, dtype=np.int64)
    qout = np.empty(nq, dtype=np.int64)
    for r in range(nq):
        p = pos_of[queries[r]]
        t = start[p]
        qout[t] = r
        qpos[t] = p
        start[p] = t + 1
    qcells = np.empty(nq, dtype=np.int64)
    qstart = np.empty(nq + 1, dtype=np.int64)
    n_groups = 0
    c = 0
    for t in range(nq):
        while cstart[c + 1] <= qpos[t]:
            c += 1
        if n_groups == 0 or qcells[n_groups - 1] != c:
            qcells[n_groups] = c
            qstart[n_groups] = t
            n_groups += 1
    qstart[n_groups] = nq
    return qcells[:n_groups].copy(), qstart[: n_groups + 1].copy(), qpos, qout
