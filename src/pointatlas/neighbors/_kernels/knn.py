"""k nearest neighbours on the grid, and the exact selection of the k-d tree path
(numba kernels; validated input assumed).

Ordering convention: a neighbour j of query q is keyed by ``(d2, j)`` with
``d2 = dx*dx + dy*dy + dz*dz`` in float64 (evaluated in exactly this order), so
exact ties are broken by the smaller index; column 0 of a row is the query itself.
See `grid` for the sorted-cell grid.
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from ..._core.tolerances import GRID_CELL_MARGIN, KDTREE_CERTIFY_RTOL
from .grid import (
    cell_coords,
    chunk_cells,
    column_range,
    interleaved_chunks,
    lower_bound,
    sq_dist,
)

__all__ = ["knn_grid", "select_candidates", "sqrt_inplace"]

#: an empty buffer slot (larger than every index)
_SENTINEL = np.iinfo(np.int64).max


@njit(cache=True, inline="always")
def _box_d2(qx, qy, qz, x0, x1, y0, y1, z0, z1, margin):
    """Squared distance from q to a box, shrunk by ``margin`` (conservative)."""
    gx = max(x0 - qx, qx - x1) - margin
    gy = max(y0 - qy, qy - y1) - margin
    gz = max(z0 - qz, qz - z1) - margin
    d = 0.0
    if gx > 0.0:
        d += gx * gx
    if gy > 0.0:
        d += gy * gy
    if gz > 0.0:
        d += gz * gz
    return d


@njit(cache=True, inline="always")
def _insert(bd, bi, d2, j):
    """Insert (d2, j) into the buffer sorted by (d2, index), dropping the worst."""
    pos = bd.shape[0] - 1
    while pos > 0 and (bd[pos - 1] > d2 or (bd[pos - 1] == d2 and bi[pos - 1] > j)):
        bd[pos] = bd[pos - 1]
        bi[pos] = bi[pos - 1]
        pos -= 1
    bd[pos] = d2
    bi[pos] = j


@njit(cache=True, inline="always")
def _scan(xs, ys, zs, ids, a, b, qx, qy, qz, qid, bd, bi):
    """Offer the points a..b (cell order) to the buffer of query ``qid``."""
    last = bd.shape[0] - 1
    for p in range(a, b):
        d2 = sq_dist(xs, ys, zs, p, qx, qy, qz)
        w = bd[last]
        if d2 < w or (d2 == w and ids[p] < bi[last]):
            j = ids[p]
            if j != qid:
                _insert(bd, bi, d2, j)


@njit(cache=True, inline="always")
def _face_bound(q, lo, h, c, r, n_cells_axis, margin):
    """Distance from coordinate q to the faces of the block c-r..c+r on one axis."""
    b = np.inf
    if c - r > 0:
        b = min(b, q - (lo + (c - r) * h))
    if c + r < n_cells_axis - 1:
        b = min(b, (lo + (c + r + 1) * h) - q)
    return b - margin


@njit(cache=True, inline="always")
def _done(bd, bi, qx, qy, qz, lo, h, ci, cj, ck, r, nx, ny, nz, margin):
    """Whether the buffer is full and its last distance certified by ring r (every
    point outside the block of rings 0..r is farther)."""
    last = bd.shape[0] - 1
    if bi[last] == _SENTINEL:
        return False
    b = min(
        _face_bound(qx, lo[0], h, ci, r, nx, margin),
        _face_bound(qy, lo[1], h, cj, r, ny, margin),
        _face_bound(qz, lo[2], h, ck, r, nz, margin),
    )
    if b == np.inf:
        return True
    if b <= 0.0:
        return False
    return bd[last] < b * b


@njit(cache=True)
def _scan_shell(
    xs,
    ys,
    zs,
    ids,
    ukeys,
    cstart,
    lo,
    h,
    ci,
    cj,
    ck,
    r,
    nx,
    ny,
    nz,
    margin,
    qx,
    qy,
    qz,
    qid,
    bd,
    bi,
):
    """Scan the cells at Chebyshev distance exactly r from cell (ci, cj, ck)."""
    last = bd.shape[0] - 1
    for i in range(max(ci - r, 0), min(ci + r, nx - 1) + 1):
        x0 = lo[0] + i * h
        for j in range(max(cj - r, 0), min(cj + r, ny - 1) + 1):
            y0 = lo[1] + j * h
            if abs(i - ci) == r or abs(j - cj) == r:
                z0 = max(ck - r, 0)
                z1 = min(ck + r, nz - 1)
                if bi[last] != _SENTINEL:
                    bx = _box_d2(
                        qx,
                        qy,
                        qz,
                        x0,
                        x0 + h,
                        y0,
                        y0 + h,
                        lo[2] + z0 * h,
                        lo[2] + (z1 + 1) * h,
                        margin,
                    )
                    if bx > bd[last]:
                        continue
                a, b = column_range(ukeys, cstart, i, j, z0, z1, ny, nz)
                _scan(xs, ys, zs, ids, a, b, qx, qy, qz, qid, bd, bi)
            else:
                for z in (ck - r, ck + r):
                    if z < 0 or z > nz - 1:
                        continue
                    a, b = column_range(ukeys, cstart, i, j, z, z, ny, nz)
                    if a < b:
                        _scan(xs, ys, zs, ids, a, b, qx, qy, qz, qid, bd, bi)


@njit(cache=True, inline="always")
def _block_cells(
    ukeys, cstart, lo, h, ci, cj, ck, nx, ny, nz,
    cell_c, cell_cls, lst_a, lst_b, lst_x, lst_y, lst_z,
):  # fmt: skip
    """The occupied cells of the 3 x 3 x 3 block around cell (ci, cj, ck), each once:
    own cell (class 0) first, then faces, edges, corners. Entry u: point range
    ``lst_a[u]:lst_b[u]`` and box corner (``lst_x[u]``, ``lst_y[u]``, ``lst_z[u]``);
    returns their number. ``cell_c``, ``cell_cls`` (27,) are scratch."""
    z0 = max(ck - 1, 0)
    z1 = min(ck + 1, nz - 1)
    n_blk = 0
    for i in range(max(ci - 1, 0), min(ci + 1, nx - 1) + 1):
        for j in range(max(cj - 1, 0), min(cj + 1, ny - 1) + 1):
            base = (i * ny + j) * nz
            ca = lower_bound(ukeys, base + z0)
            cb = lower_bound(ukeys, base + z1 + 1)
            for cc in range(ca, cb):
                cell_c[n_blk] = cc
                cell_cls[n_blk] = abs(i - ci) + abs(j - cj) + abs(ukeys[cc] - base - ck)
                n_blk += 1
    n_lst = 0
    for cls in range(4):
        for u in range(n_blk):
            if cell_cls[u] == cls:
                cc = cell_c[u]
                kk = ukeys[cc]
                lst_a[n_lst] = cstart[cc]
                lst_b[n_lst] = cstart[cc + 1]
                lst_z[n_lst] = lo[2] + (kk % nz) * h
                tt2 = kk // nz
                lst_y[n_lst] = lo[1] + (tt2 % ny) * h
                lst_x[n_lst] = lo[0] + (tt2 // ny) * h
                n_lst += 1
    return n_lst


@njit(cache=True, inline="always")
def _knn_of_point(
    xs, ys, zs, ids, ukeys, cstart, lo, h, nx, ny, nz, m, max_ring, margin,
    p, s, e, ci, cj, ck, n_lst, lst_a, lst_b, lst_x, lst_y, lst_z, ord_d, ord_u, bd, bi,
):  # fmt: skip
    """The m nearest other points of the point at cell-order position p (in cell
    ``s:e`` at (ci, cj, ck)) into the buffer (``bd``, ``bi``), sorted by (d2, index);
    returns False when its m-th neighbour is not certified after ``max_ring`` rings.

    Own cell first, in index order, stopping once m exact duplicates are found;
    then the other block cells (`_block_cells`) sorted by their box distance,
    stopping at the first box farther than the current m-th candidate; then
    further rings (`_scan_shell`) until `_done`.
    """
    qid = ids[p]
    qx = xs[p]
    qy = ys[p]
    qz = zs[p]
    for u in range(m):
        bd[u] = np.inf
        bi[u] = _SENTINEL
    # own cell, in index order: stop once m exact duplicates are found
    for pp in range(s, e):
        if bd[m - 1] == 0.0:
            break
        d2 = sq_dist(xs, ys, zs, pp, qx, qy, qz)
        w = bd[m - 1]
        if d2 < w or (d2 == w and ids[pp] < bi[m - 1]):
            if ids[pp] != qid:
                _insert(bd, bi, d2, ids[pp])
    if bd[m - 1] == 0.0:
        return True
    # the other block cells nearest first (insertion sort by box distance); stop
    # at the first box farther than the current m-th candidate
    n_ord = 0
    for u in range(1, n_lst):
        x0 = lst_x[u]
        y0 = lst_y[u]
        zz = lst_z[u]
        bx = _box_d2(qx, qy, qz, x0, x0 + h, y0, y0 + h, zz, zz + h, margin)
        v = n_ord
        while v > 0 and ord_d[v - 1] > bx:
            ord_d[v] = ord_d[v - 1]
            ord_u[v] = ord_u[v - 1]
            v -= 1
        ord_d[v] = bx
        ord_u[v] = u
        n_ord += 1
    for v in range(n_ord):
        if ord_d[v] > bd[m - 1]:
            break
        u = ord_u[v]
        _scan(xs, ys, zs, ids, lst_a[u], lst_b[u], qx, qy, qz, qid, bd, bi)
    r = 1
    while not _done(bd, bi, qx, qy, qz, lo, h, ci, cj, ck, r, nx, ny, nz, margin):
        if r >= max_ring:
            return False
        r += 1
        _scan_shell(
            xs, ys, zs, ids, ukeys, cstart, lo, h, ci, cj, ck, r, nx, ny, nz, margin,
            qx, qy, qz, qid, bd, bi,
        )  # fmt: skip
    return True


@njit(cache=True, parallel=True)
def knn_grid(
    xs, ys, zs, ids, ukeys, cstart, lo, h, nx, ny, nz, k, max_ring, out_idx, out_d2, failed
):
    """k nearest neighbours (itself in column 0) of every point, on the grid.

    Per occupied cell, the occupied cells of its 3 x 3 x 3 block are listed once
    (`_block_cells`); every query of the cell then runs `_knn_of_point`. Rows are
    written at the points' original indices. A query whose k-th neighbour is not
    certified after ``max_ring`` rings sets ``failed`` (the caller answers those
    rows with the k-d tree path).
    """
    m = k - 1
    margin = GRID_CELL_MARGIN * h
    n_cells = ukeys.shape[0]
    n_chunks, stride = interleaved_chunks(n_cells)
    for t in prange(n_chunks):
        c0, c1 = chunk_cells(t, stride, n_chunks, n_cells)
        # the query's buffer of its m best (squared distance, index), sorted
        bd = np.empty(max(m, 1))
        bi = np.empty(max(m, 1), dtype=np.int64)
        # the block's cells: scratch, then point ranges and box corners in order
        cell_c = np.empty(27, dtype=np.int64)
        cell_cls = np.empty(27, dtype=np.int64)
        lst_a = np.empty(27, dtype=np.int64)
        lst_b = np.empty(27, dtype=np.int64)
        lst_x = np.empty(27)
        lst_y = np.empty(27)
        lst_z = np.empty(27)
        # the block's cells by box distance from the query
        ord_d = np.empty(27)
        ord_u = np.empty(27, dtype=np.int64)
        for c in range(c0, c1):
            ci, cj, ck = cell_coords(ukeys[c], ny, nz)
            n_lst = _block_cells(
                ukeys, cstart, lo, h, ci, cj, ck, nx, ny, nz,
                cell_c, cell_cls, lst_a, lst_b, lst_x, lst_y, lst_z,
            )  # fmt: skip
            s = cstart[c]
            e = cstart[c + 1]
            for p in range(s, e):
                qid = ids[p]
                out_idx[qid, 0] = qid
                out_d2[qid, 0] = 0.0
                if m == 0:
                    continue
                if not _knn_of_point(
                    xs, ys, zs, ids, ukeys, cstart, lo, h, nx, ny, nz, m, max_ring, margin,
                    p, s, e, ci, cj, ck, n_lst, lst_a, lst_b, lst_x, lst_y, lst_z,
                    ord_d, ord_u, bd, bi,
                ):  # fmt: skip
                    failed[qid] = True
                for u in range(m):
                    out_idx[qid, u + 1] = bi[u]
                    out_d2[qid, u + 1] = bd[u]


# ------------------------------------------------------------------- k-d tree path


@njit(cache=True, parallel=True)
def select_candidates(pts, rows, cand, last_d2, k, all_points, out_idx, out_d2, resolved):
    """Exact (d2, index) selection among k-d tree candidates.

    ``cand[r]`` are the tree's nearest candidates of ``rows[r]`` (``n`` pads
    missing ones) and ``last_d2[r]`` the tree's largest squared distance among
    them. A row is resolved when every point outside the candidates is
    certainly farther than the selected (k-1)-th other point, or when the
    candidates are all points.
    """
    n = pts.shape[0]
    m = k - 1
    for r in prange(rows.shape[0]):
        q = rows[r]
        bd = np.full(m, np.inf)
        bi = np.full(m, _SENTINEL, dtype=np.int64)
        qx = pts[q, 0]
        qy = pts[q, 1]
        qz = pts[q, 2]
        for c in range(cand.shape[1]):
            j = cand[r, c]
            if j == q or j >= n:
                continue
            dx = pts[j, 0] - qx
            dy = pts[j, 1] - qy
            dz = pts[j, 2] - qz
            d2 = dx * dx + dy * dy + dz * dz
            if d2 < bd[m - 1] or (d2 == bd[m - 1] and j < bi[m - 1]):
                _insert(bd, bi, d2, j)
        out_idx[r, 0] = q
        out_d2[r, 0] = 0.0
        for c in range(m):
            out_idx[r, c + 1] = bi[c]
            out_d2[r, c + 1] = bd[c]
        full = bi[m - 1] != _SENTINEL
        resolved[r] = all_points or (full and last_d2[r] * (1.0 - KDTREE_CERTIFY_RTOL) > bd[m - 1])


@njit(cache=True, parallel=True)
def sqrt_inplace(a):
    """Element-wise square root of a 2-D array, in place."""
    flat = a.reshape(-1)
    for p in prange(flat.shape[0]):
        flat[p] = np.sqrt(flat[p])
