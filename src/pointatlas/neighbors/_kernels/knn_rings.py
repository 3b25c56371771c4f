"""The grid k-NN's second stage: the rows the 3 x 3 x 3 block of their cell did not
finish (numba kernels; validated input assumed).

`knn.knn_grid` answers every query from its block and marks the rows the block cannot
certify; `knn_grid_rings` finishes them: a per-query scan of the block where it was
too large to gather, then further rings of cells until the row is certified. A
separate kernel, so that its code (the block scan, the ring search) compiles only for
inputs that need it: on a mesh's vertices every row is certified by its block
(fandisk at k = 8 and 12, the torus), and numba compiles a kernel together with every
kernel it calls (docs/decisions/cli.md, "First run"). The ordering convention and the
grid are those of `knn` and `grid`.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from ..._core.tolerances import GRID_CELL_MARGIN
from .grid import cell_coords, cells_in_column, sq_dist
from .knn import _NEEDS_BLOCK, _SENTINEL, _block_cells, _done, _insert

__all__ = ["knn_grid_rings"]


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


@njit(cache=True)
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


@njit(cache=True)
def _scan_shell(
    xs,
    ys,
    zs,
    ids,
    ukeys,
    cstart,
    colptr,
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
    """Scan the cells at Chebyshev distance exactly r from cell (ci, cj, ck): the
    columns of the ring's rim over z ``ck - r .. ck + r`` (skipped when their box is
    farther than the current last candidate), the inner columns at z ``ck +- r``."""
    last = bd.shape[0] - 1
    for i in range(max(ci - r, 0), min(ci + r, nx - 1) + 1):
        x0 = lo[0] + i * h
        for j in range(max(cj - r, 0), min(cj + r, ny - 1) + 1):
            y0 = lo[1] + j * h
            if abs(i - ci) == r or abs(j - cj) == r:
                z0 = max(ck - r, 0)
                z1 = min(ck + r, nz - 1)
                if bi[last] != _SENTINEL:
                    z_lo = lo[2] + z0 * h
                    z_hi = lo[2] + (z1 + 1) * h
                    bx = _box_d2(qx, qy, qz, x0, x0 + h, y0, y0 + h, z_lo, z_hi, margin)
                    if bx > bd[last]:
                        continue
                ca, cb = cells_in_column(ukeys, colptr, i, j, z0, z1, ny, nz)
                if ca < cb:
                    _scan(xs, ys, zs, ids, cstart[ca], cstart[cb], qx, qy, qz, qid, bd, bi)
            else:
                for z in (ck - r, ck + r):
                    if z < 0 or z > nz - 1:
                        continue
                    if bi[last] != _SENTINEL:
                        z_lo = lo[2] + z * h
                        bx = _box_d2(qx, qy, qz, x0, x0 + h, y0, y0 + h, z_lo, z_lo + h, margin)
                        if bx > bd[last]:
                            continue
                    ca, cb = cells_in_column(ukeys, colptr, i, j, z, z, ny, nz)
                    if ca < cb:
                        _scan(xs, ys, zs, ids, cstart[ca], cstart[cb], qx, qy, qz, qid, bd, bi)


@njit(cache=True)
def _scan_block(
    xs,
    ys,
    zs,
    ids,
    h,
    margin,
    p,
    s,
    e,
    n_lst,
    lst_a,
    lst_b,
    lst_x,
    lst_y,
    lst_z,
    ord_d,
    ord_u,
    bd,
    bi,
):
    """The m = len(bd) nearest other points of the point at cell-order position p
    (own cell ``s:e``) among the block's cells into the buffer (``bd``, ``bi``), sorted
    by (d2, index); the path for blocks too large to gather (`_gather_block`).

    Own cell first, in index order, stopping once m exact duplicates are found;
    then the other block cells sorted by their box distance, stopping at the first
    box farther than the current m-th candidate.
    """
    m = bd.shape[0]
    qid = ids[p]
    qx = xs[p]
    qy = ys[p]
    qz = zs[p]
    for u in range(m):
        bd[u] = np.inf
        bi[u] = _SENTINEL
    for pp in range(s, e):
        if bd[m - 1] == 0.0:
            break
        d2 = sq_dist(xs, ys, zs, pp, qx, qy, qz)
        w = bd[m - 1]
        if d2 < w or (d2 == w and ids[pp] < bi[m - 1]):
            if ids[pp] != qid:
                _insert(bd, bi, d2, ids[pp])
    if bd[m - 1] == 0.0:
        return
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


#: Rings searched before `_hopeless` may hand a query to the caller's far path.
_PATIENCE = 5


@njit(cache=True)
def _hopeless(bd, bi, h, max_ring):
    """Whether ``max_ring`` rings cannot certify the query: its buffer is not full, or
    its current m-th distance exceeds ``max_ring + 1`` cells (far outliers, sparse
    halos; the caller's exact far path answers them sooner)."""
    last = bd.shape[0] - 1
    reach = (max_ring + 1) * h
    return bi[last] == _SENTINEL or bd[last] >= reach * reach


@njit(cache=True, nogil=True)
def knn_grid_rings(grid, queries, outputs, k, max_ring, pending, t0, t1):
    """Finish ``slots[t0:t1]`` of the query slots `knn.knn_grid` left, ``pending`` =
    ``(slots, groups, state)``: the marked slots, their groups, the marks (serial, the
    GIL released: `run_chunks` runs pieces of the range on threads).

    ``grid``, ``queries`` as for `knn.knn_grid`; ``outputs`` ``(out_idx, out_d2,
    failed)``. A `_NEEDS_BLOCK` slot takes its m = k - 1 best from its block by the
    per-query scan (`_scan_block`), the others start from the block's best in their
    row; rings follow (`_scan_shell`) until `_done`. A query not certified after
    ``max_ring`` rings, or `_hopeless` after `_PATIENCE`, sets ``failed`` (the caller
    answers those rows exactly elsewhere).
    """
    xs, ys, zs, ids, ukeys, cstart, colptr, lo, h, nx, ny, nz = grid
    qcells, qstart, qpos, qout = queries
    out_idx, out_d2, failed = outputs
    slots, groups, state = pending
    m = k - 1
    margin = GRID_CELL_MARGIN * h
    bd = np.empty(m)
    bi = np.empty(m, dtype=np.int64)
    cell_c = np.empty(27, dtype=np.int64)
    cell_cls = np.empty(27, dtype=np.int64)
    lst_a = np.empty(27, dtype=np.int64)
    lst_b = np.empty(27, dtype=np.int64)
    lst_x = np.empty(27)
    lst_y = np.empty(27)
    lst_z = np.empty(27)
    ord_d = np.empty(27)
    ord_u = np.empty(27, dtype=np.int64)
    for t in range(t0, t1):
        w = slots[t]
        c = qcells[groups[t]]
        p = qpos[w]
        row = qout[w]
        ci, cj, ck = cell_coords(ukeys[c], ny, nz)
        qx = xs[p]
        qy = ys[p]
        qz = zs[p]
        if state[w] == _NEEDS_BLOCK:
            n_lst = _block_cells(
                ukeys,
                cstart,
                colptr,
                lo,
                h,
                ci,
                cj,
                ck,
                nx,
                ny,
                nz,
                cell_c,
                cell_cls,
                lst_a,
                lst_b,
                lst_x,
                lst_y,
                lst_z,
            )
            _scan_block(
                xs,
                ys,
                zs,
                ids,
                h,
                margin,
                p,
                cstart[c],
                cstart[c + 1],
                n_lst,
                lst_a,
                lst_b,
                lst_x,
                lst_y,
                lst_z,
                ord_d,
                ord_u,
                bd,
                bi,
            )
        else:
            for u in range(m):
                bi[u] = out_idx[row, u + 1]
                bd[u] = out_d2[row, u + 1]
        r = np.int64(1)  # not a literal: `_done` compiles for int64 only
        while not _done(bd, bi, qx, qy, qz, lo, h, ci, cj, ck, r, nx, ny, nz, margin):
            if r >= max_ring or (r >= _PATIENCE and _hopeless(bd, bi, h, max_ring)):
                failed[row] = True
                break
            r += 1
            _scan_shell(
                xs,
                ys,
                zs,
                ids,
                ukeys,
                cstart,
                colptr,
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
                ids[p],
                bd,
                bi,
            )
        out_idx[row, 0] = ids[p]
        out_d2[row, 0] = 0.0
        for u in range(m):
            out_idx[row, u + 1] = bi[u]
            out_d2[row, u + 1] = bd[u]
