"""Radius (closed-ball) queries on the grid and row sorting (numba; validated input).

Rows are ordered by (d2, index) after the point itself, as in `grid`'s notes.
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from .grid import cell_coords, chunk_cells, column_range, interleaved_chunks, sq_dist

__all__ = ["radius_grid", "sort_rows"]


@njit(cache=True)
def _sort_pairs(d, idx, a, b):
    """Sort d[a:b], idx[a:b] together by (d, idx); insertion or heap sort."""
    m = b - a
    if m <= 24:
        for p in range(a + 1, b):
            dv = d[p]
            iv = idx[p]
            q = p
            while q > a and (d[q - 1] > dv or (d[q - 1] == dv and idx[q - 1] > iv)):
                d[q] = d[q - 1]
                idx[q] = idx[q - 1]
                q -= 1
            d[q] = dv
            idx[q] = iv
        return
    # heap sort (keys are unique because indices are)
    for start in range((m - 2) // 2, -1, -1):
        _sift(d, idx, a, start, m)
    for end in range(m - 1, 0, -1):
        d[a], d[a + end] = d[a + end], d[a]
        idx[a], idx[a + end] = idx[a + end], idx[a]
        _sift(d, idx, a, 0, end)


@njit(cache=True)
def _sift(d, idx, a, root, size):
    while True:
        child = 2 * root + 1
        if child >= size:
            return
        c = a + child
        if child + 1 < size:
            c2 = c + 1
            if d[c2] > d[c] or (d[c2] == d[c] and idx[c2] > idx[c]):
                c = c2
                child += 1
        r = a + root
        if d[c] > d[r] or (d[c] == d[r] and idx[c] > idx[r]):
            d[r], d[c] = d[c], d[r]
            idx[r], idx[c] = idx[c], idx[r]
            root = child
        else:
            return


@njit(cache=True, parallel=True)
def radius_grid(
    xs, ys, zs, ids, ukeys, cstart, lo, h, nx, ny, nz, r2, counts, indptr, out_idx, out_d2, fill
):
    """Closed-ball neighbours (d2 <= r2) on a grid with cell size h >= radius.

    First call with ``fill=False`` writes ``counts`` (by original index); second
    call with ``fill=True`` writes rows at ``indptr``: the point itself first,
    then by (d2, index).
    """
    n_cells = ukeys.shape[0]
    n_chunks, stride = interleaved_chunks(n_cells)
    for t in prange(n_chunks):
        c0, c1 = chunk_cells(t, stride, n_chunks, n_cells)
        col_a = np.empty(9, dtype=np.int64)
        col_b = np.empty(9, dtype=np.int64)
        for c in range(c0, c1):
            ci, cj, ck = cell_coords(ukeys[c], ny, nz)
            z0 = max(ck - 1, 0)
            z1 = min(ck + 1, nz - 1)
            n_col = 0
            for i in range(max(ci - 1, 0), min(ci + 1, nx - 1) + 1):
                for j in range(max(cj - 1, 0), min(cj + 1, ny - 1) + 1):
                    a, b = column_range(ukeys, cstart, i, j, z0, z1, ny, nz)
                    if a < b:
                        col_a[n_col] = a
                        col_b[n_col] = b
                        n_col += 1
            for p in range(cstart[c], cstart[c + 1]):
                qid = ids[p]
                qx = xs[p]
                qy = ys[p]
                qz = zs[p]
                if fill:
                    pos = indptr[qid]
                    out_idx[pos] = qid
                    out_d2[pos] = 0.0
                    pos += 1
                    for cc in range(n_col):
                        for pp in range(col_a[cc], col_b[cc]):
                            d2 = sq_dist(xs, ys, zs, pp, qx, qy, qz)
                            if d2 <= r2 and pp != p:
                                out_idx[pos] = ids[pp]
                                out_d2[pos] = d2
                                pos += 1
                    _sort_pairs(out_d2, out_idx, indptr[qid] + 1, pos)
                else:
                    cnt = 0
                    for cc in range(n_col):
                        for pp in range(col_a[cc], col_b[cc]):
                            d2 = sq_dist(xs, ys, zs, pp, qx, qy, qz)
                            if d2 <= r2:
                                cnt += 1
                    counts[qid] = cnt


@njit(cache=True, parallel=True)
def sort_rows(indptr, idx, d2):
    """Sort every CSR row after its first entry by (d2, index), in place."""
    n = indptr.shape[0] - 1
    for i in prange(n):
        _sort_pairs(d2, idx, indptr[i] + 1, indptr[i + 1])
