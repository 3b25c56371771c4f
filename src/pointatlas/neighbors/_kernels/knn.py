"""k nearest neighbours on the grid from each cell's 3 x 3 x 3 block (the rows it
leaves are finished by `knn_rings`), the exact selection of the k-d tree path and the
scan of all points for far queries (numba kernels; validated input assumed).

Ordering convention: a neighbour j of query q is keyed by ``(d2, j)`` with
``d2 = dx*dx + dy*dy + dz*dz`` in float64 (evaluated in exactly this order), so exact ties
are broken by the smaller index; column 0 of a row is the query itself. See `grid` for the
sorted-cell grid and its column index. Every path computes the same d2 of the same pairs and
certifies its rows, so all give the same rows bit for bit (docs/decisions/neighbors.md,
"Backends"). Only per-point leaf helpers are ``inline="always"`` (slow for numba to compile).
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from ..._core.tolerances import GRID_CELL_MARGIN, KDTREE_CERTIFY_RTOL
from .grid import cell_coords, cells_in_column

__all__ = ["knn_brute", "knn_grid", "select_candidates", "sqrt_inplace"]

#: an empty buffer slot (larger than every index)
_SENTINEL = np.iinfo(np.int64).max


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


@njit(cache=True)
def _face_bound(q, lo, h, c, r, n_cells_axis, margin):
    """Distance from coordinate q to the faces of the block c-r..c+r on one axis."""
    b = np.inf
    if c - r > 0:
        b = min(b, q - (lo + (c - r) * h))
    if c + r < n_cells_axis - 1:
        b = min(b, (lo + (c + r + 1) * h) - q)
    return b - margin


@njit(cache=True)
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
def _block_cells(
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
):
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
            ca, cb = cells_in_column(ukeys, colptr, i, j, z0, z1, ny, nz)
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
def _count_within(dd, n, tau):
    """How many of ``dd[:n]`` are <= tau (branch-free)."""
    c = 0
    for t in range(n):
        c += dd[t] <= tau
    return c


@njit(cache=True)
def _select_gathered(dd, gi, n, t_self, tau, sd, si, sr, bd, bi):
    """The m = len(bd) smallest (d2, index) of the gathered block (``dd[:n]``,
    ``gi[:n]``; entry ``t_self`` is the query) into the buffer, sorted.

    A threshold ``tau`` (a guess: the previous query's m-th d2) is widened or
    narrowed (by the ratio a surface's count changes with, count ~ d2) until at least
    m and, where a try allows, at most `_SELECT_SLACK` m others lie within it (at most
    8 narrowing tries; exact ties can keep more inside); those are placed
    at their rank among themselves (rank = how many of them precede by (d2, index)),
    which is their rank among all entries (``sr`` is scratch). The ranks are counted
    by d2 alone first, one comparison a pair (the kernel 0.54 -> 0.51 s on a
    742,000-point lidar tile, k = 20, one thread), and again by (d2, index) when their
    sum shows a tie. Returns False (buffer untouched) when more than 4m + 16 entries
    tie inside every tried threshold (exact duplicates).
    """
    m = bd.shape[0]
    cnt = _count_within(dd, n, tau) - 1
    it = 0
    while cnt < m and cnt < n - 1:
        # widen, by the ratio a surface's count grows with (count ~ d2), at least 1.25x
        grow = min(max(1.1 * m / max(cnt, 1), 1.25), 4.0)
        tau = tau * grow if tau > 0.0 else 1e-300
        it += 1
        if it > 64:
            tau = np.inf
        cnt = _count_within(dd, n, tau) - 1
    it = 0
    while cnt > _SELECT_SLACK * m and it < 8:
        narrower = tau * min(max(1.1 * m / cnt, 0.5), 0.95)
        c2 = _count_within(dd, n, narrower) - 1
        if c2 < m:
            break
        tau = narrower
        cnt = c2
        it += 1
    if cnt > 4 * m + 16:
        return False
    c = 0
    for t in range(n):
        sd[c] = dd[t]
        si[c] = gi[t]
        c += (dd[t] <= tau) & (t != t_self)
    # rank by d2 alone (one comparison a pair): the ranks are a permutation of
    # 0..c-1, summing to c(c-1)/2, exactly when no two of them tie; else by (d2, index)
    total = 0
    for a in range(c):
        da = sd[a]
        rank = 0
        for b in range(c):
            rank += sd[b] < da
        sr[a] = rank
        total += rank
    if total == c * (c - 1) // 2:
        for a in range(c):
            if sr[a] < m:
                bd[sr[a]] = sd[a]
                bi[sr[a]] = si[a]
    else:
        for a in range(c):
            da = sd[a]
            ia = si[a]
            rank = 0
            for b in range(c):
                db = sd[b]
                rank += (db < da) | ((db == da) & (si[b] < ia))
            if rank < m:
                bd[rank] = da
                bi[rank] = ia
    for u in range(c, m):
        bd[u] = np.inf
        bi[u] = _SENTINEL
    return True


@njit(cache=True)
def _gather_block(xs, ys, zs, ids, n_lst, lst_a, lst_b, gx, gy, gz, gi):
    """Copy the block's points (own cell first) into ``gx, gy, gz, gi``; returns their
    number, or -1 when they do not fit."""
    n = 0
    for u in range(n_lst):
        n += lst_b[u] - lst_a[u]
    if n > gx.shape[0]:
        return -1
    n = 0
    for u in range(n_lst):
        for p in range(lst_a[u], lst_b[u]):
            gx[n] = xs[p]
            gy[n] = ys[p]
            gz[n] = zs[p]
            gi[n] = ids[p]
            n += 1
    return n


@njit(cache=True)
def _block_distances(gx, gy, gz, n, qx, qy, qz, dd):
    """``dd[:n]``: d2 of the gathered points from the query (the ordering convention)."""
    for t in range(n):
        dx = gx[t] - qx
        dy = gy[t] - qy
        dz = gz[t] - qz
        dd[t] = dx * dx + dy * dy + dz * dz


#: `_select_gathered` narrows its threshold while more than this many times m others
#: lie within it (their ranking costs the square of their number).
_SELECT_SLACK = 1.2

#: Gathered block size: blocks with more points take the per-query path
#: (`knn_rings._scan_block`).
_GATHER = 512

#: Rows a thread finishes into its own buffer before copying them to their output rows
#: at once (`_flush_rows`). Writing each row straight to its (scattered) output row
#: cost 0.12 of 0.65 s in the kernel on a 742,000-point lidar tile, k = 20 (one
#: thread, docs/decisions/neighbors.md "Speed").
_ROW_BUFFER = 64


@njit(cache=True)
def _flush_rows(tb_i, tb_d, tb_r, nb, out_idx, out_d2):
    """Copy the first ``nb`` buffered rows to their output rows ``tb_r[:nb]``."""
    for b in range(nb):
        row = tb_r[b]
        for u in range(tb_i.shape[1]):
            out_idx[row, u] = tb_i[b, u]
            out_d2[row, u] = tb_d[b, u]


#: `knn_grid`'s mark of a query slot: the block certified its row (final), the row
#: holds the block's best but needs further rings, or the block was too large to
#: gather (or its ties too many to select) and the row is still empty; the last two
#: are finished by `knn_rings.knn_grid_rings`
_CERTIFIED = 0
_NEEDS_RINGS = 1
_NEEDS_BLOCK = 2


@njit(cache=True, nogil=True)
def knn_grid(grid, queries, outputs, k, g0, g1):
    """k nearest neighbours (itself in column 0) of the queried points of the groups
    g0 .. g1 - 1 from the 3 x 3 x 3 block of their cell, on the grid (serial; the
    GIL released, so the caller runs pieces of the groups on several threads at
    once, `run_chunks`).

    ``grid`` is ``(xs, ys, zs, ids, ukeys, cstart, colptr, lo, h, nx, ny, nz)``,
    ``queries`` ``(qcells, qstart, qpos, qout)`` and ``outputs`` ``(out_idx, out_d2,
    state)``. Queries come grouped by cell: group g is cell ``qcells[g]`` with the
    cell-order positions ``qpos[qstart[g]:qstart[g + 1]]`` (query slots), written to
    output rows ``qout`` (all points: ``qcells = arange``, ``qstart = cstart``,
    ``qpos = arange``, ``qout = ids``). Per group the occupied cells of its block are
    listed once (`_block_cells`) and their points gathered (`_gather_block`); each
    query then takes its m = k - 1 best from the gathered block (`_select_gathered`).
    ``state`` (per query slot) records what the block left (`_NEEDS_RINGS`,
    `_NEEDS_BLOCK`); `knn_rings.knn_grid_rings` finishes those rows, so its kernels
    (the per-query block scan, the ring search) compile only for inputs that need
    them (most rows of a surface sample are certified by their block). Finished
    rows go through a buffer (`_ROW_BUFFER`). Every row is exact, so the rows do not
    depend on how the groups are split: threads rather than numba's
    ``parallel=True``, whose compile cost about 5 of the query's 15 CPU-seconds on
    an empty cache.
    """
    xs, ys, zs, ids, ukeys, cstart, colptr, lo, h, nx, ny, nz = grid
    qcells, qstart, qpos, qout = queries
    out_idx, out_d2, state = outputs
    m = k - 1
    margin = GRID_CELL_MARGIN * h
    bd = np.empty(max(m, 1))
    bi = np.empty(max(m, 1), dtype=np.int64)
    cell_c = np.empty(27, dtype=np.int64)
    cell_cls = np.empty(27, dtype=np.int64)
    lst_a = np.empty(27, dtype=np.int64)
    lst_b = np.empty(27, dtype=np.int64)
    lst_x = np.empty(27)
    lst_y = np.empty(27)
    lst_z = np.empty(27)
    gx = np.empty(_GATHER)
    gy = np.empty(_GATHER)
    gz = np.empty(_GATHER)
    gi = np.empty(_GATHER, dtype=np.int64)
    dd = np.empty(_GATHER)
    sd = np.empty(_GATHER)
    si = np.empty(_GATHER, dtype=np.int64)
    sr = np.empty(_GATHER, dtype=np.int64)
    tb_i = np.empty((_ROW_BUFFER, k), dtype=np.int64)
    tb_d = np.empty((_ROW_BUFFER, k))
    tb_r = np.empty(_ROW_BUFFER, dtype=np.int64)
    nb = np.int64(0)  # not a literal: `_flush_rows` compiles for int64 only
    one = np.int64(1)  # the first ring; not a literal: `_done` compiles for int64 only
    tau = 0.25 * h * h
    for g in range(g0, g1):
        c = qcells[g]
        ci, cj, ck = cell_coords(ukeys[c], ny, nz)
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
        s = cstart[c]
        n_g = _gather_block(xs, ys, zs, ids, n_lst, lst_a, lst_b, gx, gy, gz, gi)
        for w in range(qstart[g], qstart[g + 1]):
            p = qpos[w]
            if nb == _ROW_BUFFER:
                _flush_rows(tb_i, tb_d, tb_r, nb, out_idx, out_d2)
                nb = 0
            slot = nb
            tb_r[slot] = qout[w]
            nb += 1
            tb_i[slot, 0] = ids[p]
            tb_d[slot, 0] = 0.0
            if m == 0:
                continue
            qx = xs[p]
            qy = ys[p]
            qz = zs[p]
            done = False
            if n_g >= 0:
                _block_distances(gx, gy, gz, n_g, qx, qy, qz, dd)
                done = _select_gathered(dd, gi, n_g, p - s, tau, sd, si, sr, bd, bi)
            if not done:
                state[w] = _NEEDS_BLOCK
                continue
            if bi[m - 1] != _SENTINEL and bd[m - 1] > 0.0:
                tau = bd[m - 1] * 1.05
            if not _done(bd, bi, qx, qy, qz, lo, h, ci, cj, ck, one, nx, ny, nz, margin):
                state[w] = _NEEDS_RINGS
            for u in range(m):
                tb_i[slot, u + 1] = bi[u]
                tb_d[slot, u + 1] = bd[u]
    _flush_rows(tb_i, tb_d, tb_r, nb, out_idx, out_d2)


# ------------------------------------------------------------------- k-d tree path


@njit(cache=True)
def _offer(pts, j, qx, qy, qz, bd, bi):
    """Point ``j`` into the best list (bd, bi) of the query at (qx, qy, qz) when it
    beats the list's last by (squared distance, index)."""
    dx = pts[j, 0] - qx
    dy = pts[j, 1] - qy
    dz = pts[j, 2] - qz
    d2 = dx * dx + dy * dy + dz * dz
    m = bd.shape[0]
    if d2 < bd[m - 1] or (d2 == bd[m - 1] and j < bi[m - 1]):
        _insert(bd, bi, d2, j)


@njit(cache=True)
def _empty_row(pts, q, m):
    """An empty best list of ``m`` (squared distance, index) pairs for the query
    point ``q`` and its coordinates: the start of a k-d tree or brute-force row."""
    bd = np.full(m, np.inf)
    bi = np.full(m, _SENTINEL, dtype=np.int64)
    return bd, bi, pts[q, 0], pts[q, 1], pts[q, 2]


@njit(cache=True)
def _write_row(out_idx, out_d2, r, q, bd, bi):
    """Row ``r`` of the output: the query ``q`` itself first, then its best list."""
    out_idx[r, 0] = q
    out_d2[r, 0] = 0.0
    for c in range(bd.shape[0]):
        out_idx[r, c + 1] = bi[c]
        out_d2[r, c + 1] = bd[c]


@njit(cache=True, parallel=True)
def select_candidates(
    pts, rows, cand, last_d2, k, all_points, gptr, gmem, out_idx, out_d2, resolved
):
    """Exact (d2, index) selection among k-d tree candidates.

    The tree holds one entry per distinct position: entry g stands for the
    points ``gmem[gptr[g]:gptr[g + 1]]`` (increasing index; one point each when
    the input has no exact duplicates). ``cand[r]`` are the tree's nearest
    entries of ``rows[r]`` (the entry count pads missing ones) and ``last_d2[r]``
    the tree's largest squared distance among them. Of an entry only its first
    k points can be selected (the others tie with them at larger indices), so a
    cluster of D duplicates costs k per entry, not D. A row is resolved when
    every point outside the candidates is certainly farther than the selected
    (k-1)-th other point, or when the candidates are all entries.
    """
    n_entries = gptr.shape[0] - 1
    m = k - 1
    for r in prange(rows.shape[0]):
        q = rows[r]
        bd, bi, qx, qy, qz = _empty_row(pts, q, m)
        for c in range(cand.shape[1]):
            g = cand[r, c]
            if g < n_entries:
                stop = min(gptr[g + 1], gptr[g] + k)
                for t in range(gptr[g], stop):
                    j = gmem[t]
                    if j != q:
                        _offer(pts, j, qx, qy, qz, bd, bi)
        _write_row(out_idx, out_d2, r, q, bd, bi)
        full = bi[m - 1] != _SENTINEL
        resolved[r] = all_points or (full and last_d2[r] * (1.0 - KDTREE_CERTIFY_RTOL) > bd[m - 1])


@njit(cache=True, parallel=True)
def knn_brute(pts, rows, k, out_idx, out_d2):
    """Exact k-NN rows (squared distances) of ``rows`` by a scan of all points: the
    path for the few queries the grid leaves (far outliers)."""
    m = k - 1
    for r in prange(rows.shape[0]):
        q = rows[r]
        bd, bi, qx, qy, qz = _empty_row(pts, q, m)
        for j in range(pts.shape[0]):
            if j != q:
                _offer(pts, j, qx, qy, qz, bd, bi)
        _write_row(out_idx, out_d2, r, q, bd, bi)


@njit(cache=True)
def sqrt_inplace(a):
    """Element-wise square root of a 2-D array, in place."""
    for r in range(a.shape[0]):
        for c in range(a.shape[1]):
            a[r, c] = np.sqrt(a[r, c])
