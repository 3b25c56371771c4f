"""numba kernels for the neighbour queries (STYLE section 7).

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
from numba import njit, prange

from .._core.tolerances import GRID_CELL_MARGIN, KDTREE_CERTIFY_RTOL

_SENTINEL = np.iinfo(np.int64).max


# --------------------------------------------------------------------------- grid


@njit(cache=True)
def bounds(pts):
    """Per-axis minimum and maximum of an (N >= 1, 3) array (``pts.min(axis=0)``,
    ``pts.max(axis=0)``; numpy's strided axis-0 reductions take ~30 ms each at 1M)."""
    lo = pts[0].copy()
    hi = pts[0].copy()
    for p in range(1, pts.shape[0]):
        for d in range(3):
            v = pts[p, d]
            if v < lo[d]:
                lo[d] = v
            if v > hi[d]:
                hi[d] = v
    return lo, hi


@njit(cache=True, parallel=True)
def grid_keys(pts, lo, inv_h, nx, ny, nz):
    """Cell key of every point, clamped into the grid."""
    n = pts.shape[0]
    keys = np.empty(n, dtype=np.int64)
    for p in prange(n):
        i = np.int64(np.floor((pts[p, 0] - lo[0]) * inv_h))
        j = np.int64(np.floor((pts[p, 1] - lo[1]) * inv_h))
        kz = np.int64(np.floor((pts[p, 2] - lo[2]) * inv_h))
        i = min(max(i, 0), nx - 1)
        j = min(max(j, 0), ny - 1)
        kz = min(max(kz, 0), nz - 1)
        keys[p] = (i * ny + j) * nz + kz
    return keys


@njit(cache=True)
def cell_starts(sorted_keys):
    """Occupied cell keys and their point ranges from sorted keys."""
    n = sorted_keys.shape[0]
    n_cells = 0
    for p in range(n):
        if p == 0 or sorted_keys[p] != sorted_keys[p - 1]:
            n_cells += 1
    ukeys = np.empty(n_cells, dtype=np.int64)
    cstart = np.empty(n_cells + 1, dtype=np.int64)
    c = 0
    for p in range(n):
        if p == 0 or sorted_keys[p] != sorted_keys[p - 1]:
            ukeys[c] = sorted_keys[p]
            cstart[c] = p
            c += 1
    cstart[n_cells] = n
    return ukeys, cstart


@njit(cache=True, parallel=True)
def gather_sorted(pts, order):
    """Coordinates in cell order as three contiguous arrays (structure of arrays)."""
    n = order.shape[0]
    xs = np.empty(n)
    ys = np.empty(n)
    zs = np.empty(n)
    for p in prange(n):
        o = order[p]
        xs[p] = pts[o, 0]
        ys[p] = pts[o, 1]
        zs[p] = pts[o, 2]
    return xs, ys, zs


@njit(cache=True, parallel=True)
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
    for c in prange(n_cells):
        cnt = np.zeros(64, dtype=np.int64)
        same = np.ones(64, dtype=np.bool_)
        fx = np.empty(64)
        fy = np.empty(64)
        fz = np.empty(64)
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


@njit(cache=True, inline="always")
def _lower_bound(a, x):
    lo = 0
    hi = a.shape[0]
    while lo < hi:
        mid = (lo + hi) >> 1
        if a[mid] < x:
            lo = mid + 1
        else:
            hi = mid
    return lo


@njit(cache=True)
def _column_range(ukeys, cstart, i, j, z0, z1, ny, nz):
    """Point range of cells (i, j, z0..z1) (inclusive, already clipped)."""
    base = (i * ny + j) * nz
    a = _lower_bound(ukeys, base + z0)
    b = _lower_bound(ukeys, base + z1 + 1)
    return cstart[a], cstart[b]


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
    last = bd.shape[0] - 1
    for p in range(a, b):
        dx = xs[p] - qx
        dy = ys[p] - qy
        dz = zs[p] - qz
        d2 = dx * dx + dy * dy + dz * dz
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
                a, b = _column_range(ukeys, cstart, i, j, z0, z1, ny, nz)
                _scan(xs, ys, zs, ids, a, b, qx, qy, qz, qid, bd, bi)
            else:
                for z in (ck - r, ck + r):
                    if z < 0 or z > nz - 1:
                        continue
                    a, b = _column_range(ukeys, cstart, i, j, z, z, ny, nz)
                    if a < b:
                        _scan(xs, ys, zs, ids, a, b, qx, qy, qz, qid, bd, bi)


@njit(cache=True, parallel=True)
def knn_grid(
    xs, ys, zs, ids, ukeys, cstart, lo, h, nx, ny, nz, k, max_ring, out_idx, out_d2, failed
):
    """k nearest neighbours (itself in column 0) of every point, on the grid.

    Per occupied cell, the occupied cells of its 3 x 3 x 3 block are listed once.
    Every query of the cell scans its own cell first (in index order, stopping
    once k - 1 exact duplicates are found), then the other block cells sorted by
    their box distance, stopping at the first box farther than its current
    k-th candidate, then further rings until certified. Rows are written at the
    points' original indices. A query whose k-th neighbour is not certified after
    ``max_ring`` rings sets ``failed`` (the caller answers those rows with the
    k-d tree path).
    """
    m = k - 1
    n_cells = ukeys.shape[0]
    margin = GRID_CELL_MARGIN * h
    # interleave cells over the static thread blocks (load balance)
    n_chunks = min(n_cells, 4096)
    stride = 2654435761 % n_chunks if n_chunks > 1 else 1
    while n_chunks > 1 and _gcd(stride, n_chunks) != 1:
        stride += 1
    for t in prange(n_chunks):
        chunk = (t * stride) % n_chunks
        c0 = chunk * n_cells // n_chunks
        c1 = (chunk + 1) * n_cells // n_chunks
        bd = np.empty(max(m, 1))
        bi = np.empty(max(m, 1), dtype=np.int64)
        cell_c = np.empty(27, dtype=np.int64)
        cell_cls = np.empty(27, dtype=np.int64)
        lst_a = np.empty(27, dtype=np.int64)
        lst_b = np.empty(27, dtype=np.int64)
        lst_x = np.empty(27)
        lst_y = np.empty(27)
        lst_z = np.empty(27)
        ord_d = np.empty(27)
        ord_u = np.empty(27, dtype=np.int64)
        for c in range(c0, c1):
            key = ukeys[c]
            ck = key % nz
            tt = key // nz
            cj = tt % ny
            ci = tt // ny
            z0 = max(ck - 1, 0)
            z1 = min(ck + 1, nz - 1)
            n_blk = 0
            for i in range(max(ci - 1, 0), min(ci + 1, nx - 1) + 1):
                for j in range(max(cj - 1, 0), min(cj + 1, ny - 1) + 1):
                    base = (i * ny + j) * nz
                    ca = _lower_bound(ukeys, base + z0)
                    cb = _lower_bound(ukeys, base + z1 + 1)
                    for cc in range(ca, cb):
                        cell_c[n_blk] = cc
                        cell_cls[n_blk] = abs(i - ci) + abs(j - cj) + abs(ukeys[cc] - base - ck)
                        n_blk += 1
            # order: own cell (class 0), faces, edges, corners
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
            s = cstart[c]
            e = cstart[c + 1]
            for p in range(s, e):
                qid = ids[p]
                out_idx[qid, 0] = qid
                out_d2[qid, 0] = 0.0
                if m == 0:
                    continue
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
                    dx = xs[pp] - qx
                    dy = ys[pp] - qy
                    dz = zs[pp] - qz
                    d2 = dx * dx + dy * dy + dz * dz
                    w = bd[m - 1]
                    if d2 < w or (d2 == w and ids[pp] < bi[m - 1]):
                        if ids[pp] != qid:
                            _insert(bd, bi, d2, ids[pp])
                if bd[m - 1] != 0.0:
                    # the other block cells nearest first; stop at the first box
                    # farther than the current k-th candidate
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
                            failed[qid] = True
                            break
                        r += 1
                        _scan_shell(
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
                        )
                for u in range(m):
                    out_idx[qid, u + 1] = bi[u]
                    out_d2[qid, u + 1] = bd[u]


@njit(cache=True)
def _gcd(a, b):
    while b:
        a, b = b, a % b
    return a


@njit(cache=True, parallel=True)
def sqrt_inplace(a):
    """Element-wise square root of a 2-D array, in place."""
    flat = a.reshape(-1)
    for p in prange(flat.shape[0]):
        flat[p] = np.sqrt(flat[p])


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


# ------------------------------------------------------------------------- radius


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
    n_chunks = min(n_cells, 4096)
    stride = 2654435761 % n_chunks if n_chunks > 1 else 1
    while n_chunks > 1 and _gcd(stride, n_chunks) != 1:
        stride += 1
    for t in prange(n_chunks):
        chunk = (t * stride) % n_chunks
        c0 = chunk * n_cells // n_chunks
        c1 = (chunk + 1) * n_cells // n_chunks
        col_a = np.empty(9, dtype=np.int64)
        col_b = np.empty(9, dtype=np.int64)
        for c in range(c0, c1):
            key = ukeys[c]
            ck = key % nz
            tt = key // nz
            cj = tt % ny
            ci = tt // ny
            z0 = max(ck - 1, 0)
            z1 = min(ck + 1, nz - 1)
            n_col = 0
            for i in range(max(ci - 1, 0), min(ci + 1, nx - 1) + 1):
                for j in range(max(cj - 1, 0), min(cj + 1, ny - 1) + 1):
                    a, b = _column_range(ukeys, cstart, i, j, z0, z1, ny, nz)
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
                            dx = xs[pp] - qx
                            dy = ys[pp] - qy
                            dz = zs[pp] - qz
                            d2 = dx * dx + dy * dy + dz * dz
                            if d2 <= r2 and pp != p:
                                out_idx[pos] = ids[pp]
                                out_d2[pos] = d2
                                pos += 1
                    _sort_pairs(out_d2, out_idx, indptr[qid] + 1, pos)
                else:
                    cnt = 0
                    for cc in range(n_col):
                        for pp in range(col_a[cc], col_b[cc]):
                            dx = xs[pp] - qx
                            dy = ys[pp] - qy
                            dz = zs[pp] - qz
                            d2 = dx * dx + dy * dy + dz * dz
                            if d2 <= r2:
                                cnt += 1
                    counts[qid] = cnt


@njit(cache=True, parallel=True)
def sort_rows(indptr, idx, d2):
    """Sort every CSR row after its first entry by (d2, index), in place."""
    n = indptr.shape[0] - 1
    for i in prange(n):
        _sort_pairs(d2, idx, indptr[i] + 1, indptr[i + 1])


# -------------------------------------------------------------------------- graph


@njit(cache=True)
def _sort_ints(a, lo, hi):
    m = hi - lo
    if m <= 24:
        for p in range(lo + 1, hi):
            v = a[p]
            q = p
            while q > lo and a[q - 1] > v:
                a[q] = a[q - 1]
                q -= 1
            a[q] = v
    else:
        a[lo:hi] = np.sort(a[lo:hi])


@njit(cache=True, parallel=True)
def graph_structure(nbr, n, symmetric):
    """CSR structure (sorted, duplicate-free columns) of the k-NN graph.

    ``nbr`` holds the neighbours of every point without the point itself.
    """
    m = nbr.shape[1]
    deg = np.zeros(n, dtype=np.int64)
    for i in range(n):
        deg[i] += m
        if symmetric:
            for c in range(m):
                deg[nbr[i, c]] += 1
    ptr = np.zeros(n + 1, dtype=np.int64)
    for i in range(n):
        ptr[i + 1] = ptr[i] + deg[i]
    cols = np.empty(ptr[n], dtype=np.int64)
    pos = ptr[:-1].copy()
    for i in range(n):
        for c in range(m):
            j = nbr[i, c]
            cols[pos[i]] = j
            pos[i] += 1
            if symmetric:
                cols[pos[j]] = i
                pos[j] += 1
    new_deg = np.zeros(n, dtype=np.int64)
    for i in prange(n):
        a = ptr[i]
        b = ptr[i + 1]
        _sort_ints(cols, a, b)
        w = a
        for p in range(a, b):
            if p == a or cols[p] != cols[p - 1]:
                cols[w] = cols[p]
                w += 1
        new_deg[i] = w - a
    indptr = np.zeros(n + 1, dtype=np.int64)
    for i in range(n):
        indptr[i + 1] = indptr[i] + new_deg[i]
    out = np.empty(indptr[n], dtype=np.int64)
    for i in prange(n):
        out[indptr[i] : indptr[i + 1]] = cols[ptr[i] : ptr[i] + new_deg[i]]
    return indptr, out


@njit(cache=True, parallel=True)
def edge_lengths(pts, indptr, cols):
    """Euclidean length of every stored edge (row i, column cols[p])."""
    n = indptr.shape[0] - 1
    out = np.empty(cols.shape[0])
    for i in prange(n):
        for p in range(indptr[i], indptr[i + 1]):
            j = cols[p]
            dx = pts[j, 0] - pts[i, 0]
            dy = pts[j, 1] - pts[i, 1]
            dz = pts[j, 2] - pts[i, 2]
            out[p] = np.sqrt(dx * dx + dy * dy + dz * dz)
    return out
