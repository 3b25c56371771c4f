"""numba kernels of the segmentation room (inputs are validated by the callers).

Every kernel has a plain-numpy/Python reference in ``tests/segment/reference.py``.
Graphs are symmetric CSR structures ``(indptr, indices)`` without self loops, rows
sorted increasingly.
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from .._core._prefetch import prefetch_row as _prefetch
from .._core._sort import radix_sort_payload

# --------------------------------------------------------------------------- graph


@njit(cache=True)
def symmetric_csr(nbr, n):
    """Symmetric CSR adjacency of a directed neighbour table.

    ``nbr`` is (N, c) int64; entries < 0 or equal to the row are ignored.
    Returns (indptr, indices) with sorted, duplicate-free rows.
    """
    deg = np.zeros(n, dtype=np.int64)
    for i in range(nbr.shape[0]):
        for t in range(nbr.shape[1]):
            j = nbr[i, t]
            if j >= 0 and j != i:
                deg[i] += 1
                deg[j] += 1
    ptr = np.zeros(n + 1, dtype=np.int64)
    for i in range(n):
        ptr[i + 1] = ptr[i] + deg[i]
    fill = ptr[:-1].copy()
    raw = np.empty(ptr[n], dtype=np.int64)
    for i in range(nbr.shape[0]):
        for t in range(nbr.shape[1]):
            j = nbr[i, t]
            if j >= 0 and j != i:
                raw[fill[i]] = j
                fill[i] += 1
                raw[fill[j]] = i
                fill[j] += 1
    # sort (insertion sort: rows are short) and de-duplicate every row, compacting
    out_ptr = np.zeros(n + 1, dtype=np.int64)
    pos = 0
    for i in range(n):
        lo = ptr[i]
        hi = ptr[i + 1]
        for a in range(lo + 1, hi):
            v = raw[a]
            b = a - 1
            while b >= lo and raw[b] > v:
                raw[b + 1] = raw[b]
                b -= 1
            raw[b + 1] = v
        last = -1
        for t in range(lo, hi):
            if raw[t] != last:
                raw[pos] = raw[t]
                pos += 1
                last = raw[t]
        out_ptr[i + 1] = pos
    return out_ptr, raw[:pos].copy()


@njit(cache=True)
def _find(parent, i):
    root = i
    while parent[root] != root:
        root = parent[root]
    while parent[i] != root:  # path compression
        nxt = parent[i]
        parent[i] = root
        i = nxt
    return root


@njit(cache=True)
def canonical_labels(labels):
    """Renumber labels 0..m-1 by first occurrence; returns (new_labels, m)."""
    n = labels.shape[0]
    top = 0
    for i in range(n):
        if labels[i] > top:
            top = labels[i]
    remap = np.full(top + 1, -1, dtype=np.int64)
    out = np.empty(n, dtype=np.int64)
    m = 0
    for i in range(n):
        lab = labels[i]
        if remap[lab] < 0:
            remap[lab] = m
            m += 1
        out[i] = remap[lab]
    return out, m


@njit(cache=True)
def connected_label_components(indptr, indices, labels):
    """Split every label into its connected pieces in the graph.

    Returns labels numbered 0..m-1 by smallest member index, and m.
    """
    n = labels.shape[0]
    parent = np.arange(n)
    for i in range(n):
        for t in range(indptr[i], indptr[i + 1]):
            j = indices[t]
            if j > i and labels[j] == labels[i]:
                ri = _find(parent, i)
                rj = _find(parent, j)
                if ri != rj:
                    if ri < rj:
                        parent[rj] = ri
                    else:
                        parent[ri] = rj
    roots = np.empty(n, dtype=np.int64)
    for i in range(n):
        roots[i] = _find(parent, i)
    return canonical_labels(roots)


@njit(cache=True)
def region_pairs(indptr, indices, labels, subset):
    """Distinct region pairs (a < b) joined by a graph edge at a point of ``subset``.

    With ``subset`` the boundary points (or all points) that is the region
    adjacency of Remark 6. Sorted by (a, b).
    """
    count = 0
    for s in range(subset.shape[0]):
        i = subset[s]
        for t in range(indptr[i], indptr[i + 1]):
            if labels[indices[t]] > labels[i]:
                count += 1
    if count == 0:
        return np.empty((0, 2), dtype=np.int64)
    m = 0
    for i in range(labels.shape[0]):
        if labels[i] + 1 > m:
            m = labels[i] + 1
    key = np.empty(count, dtype=np.int64)
    c = 0
    for s in range(subset.shape[0]):
        i = subset[s]
        li = labels[i]
        for t in range(indptr[i], indptr[i + 1]):
            lj = labels[indices[t]]
            if lj > li:
                key[c] = li * m + lj
                c += 1
    return _pairs_of_keys(key, m)


#: `merge_candidate_pairs` marks pairs in a byte table (cheap regions x all
#: regions) when it has at most this many bytes per scanned point (plus 1 MiB);
#: otherwise it sorts the raw pair keys
_PAIR_TABLE_BYTES_PER_POINT = 8


@njit(cache=True, inline="always")
def _is_candidate(li, lj, dirty, cost, limit):
    """Regions li, lj (of a boundary edge) form a merge candidate: different, one of
    them changed since the last pass, and the sum of their costs below ``limit``."""
    return lj != li and (dirty[li] or dirty[lj]) and cost[li] + cost[lj] < limit


@njit(cache=True)
def _pairs_of_keys(key, m):
    """Distinct pair keys a * m + b as sorted (a, b) rows."""
    key = np.unique(key)
    out = np.empty((key.shape[0], 2), dtype=np.int64)
    out[:, 0] = key // m
    out[:, 1] = key % m
    return out


@njit(cache=True, parallel=True)
def merge_candidate_pairs(indptr, indices, labels, foreign, dirty, cost, limit, points):
    """Neighbouring region pairs (a < b, sorted) that a merge pass must look at.

    L21 is superadditive (the optimum over a union is at least the sum of the
    optima over its parts), so a union can only stay below ``limit`` when
    cost[a] + cost[b] < limit; at least one of the two then has cost < limit / 2,
    and the pairs are found from the boundary points of such regions. Pairs of
    which neither region is ``dirty`` (W, S unchanged since the last pass) are
    left out: that pass rejected them, and with unchanged sums it would again.
    Only the points in ``points`` (increasing; e.g. `touched_points` of the
    dirty regions, which holds every boundary point with a dirty region on
    either side of an edge) are scanned.

    Many boundary edges join the same two regions, so the pairs are deduplicated
    in a byte table with one row per region of cost < limit / 2 (parallel
    threads only ever store 1, so races are harmless) and the few distinct keys
    sorted; when that table would be large compared with the scan, the raw keys
    are sorted instead (`_candidate_pairs_sorted`). Same result either way.
    """
    limit = limit + 1e-9 * (1.0 + abs(limit))  # round-off slack: never drop a candidate
    half = 0.5 * limit
    n = points.shape[0]
    m = cost.shape[0]
    row = np.full(m, -1, dtype=np.int64)
    mc = 0
    for r in range(m):
        if cost[r] < half:
            row[r] = mc
            mc += 1
    if mc == 0:
        return np.empty((0, 2), dtype=np.int64)
    if mc * m > _PAIR_TABLE_BYTES_PER_POINT * n + (1 << 20):
        return _candidate_pairs_sorted(indptr, indices, labels, foreign, dirty, cost, limit, points)
    table = np.zeros(mc * m, dtype=np.uint8)
    for s in prange(n):
        i = points[s]
        if foreign[i] == 0:
            continue
        li = labels[i]
        if row[li] < 0:
            continue
        off = row[li] * m
        for t in range(indptr[i], indptr[i + 1]):
            lj = labels[indices[t]]
            if _is_candidate(li, lj, dirty, cost, limit):
                table[off + lj] = 1
    # the cheap regions in increasing order, their marked partners as keys
    cheap = np.empty(mc, dtype=np.int64)
    for r in range(m):
        if row[r] >= 0:
            cheap[row[r]] = r
    per_row = np.zeros(mc + 1, dtype=np.int64)
    for c in prange(mc):
        k = 0
        for t in range(c * m, (c + 1) * m):
            k += table[t]
        per_row[c + 1] = k
    start = np.cumsum(per_row)
    if start[mc] == 0:
        return np.empty((0, 2), dtype=np.int64)
    key = np.empty(start[mc], dtype=np.int64)
    for c in prange(mc):
        a = cheap[c]
        k = start[c]
        for b in range(m):
            if table[c * m + b]:
                key[k] = min(a, b) * m + max(a, b)
                k += 1
    return _pairs_of_keys(key, m)


@njit(cache=True, parallel=True)
def _candidate_pairs_sorted(indptr, indices, labels, foreign, dirty, cost, limit, points):
    """`merge_candidate_pairs` by sorting every qualifying edge's pair key
    (``limit`` already has its round-off slack)."""
    half = 0.5 * limit
    n = points.shape[0]
    m = cost.shape[0]
    per_point = np.zeros(n + 1, dtype=np.int64)
    for s in prange(n):
        i = points[s]
        if foreign[i] == 0:
            continue
        li = labels[i]
        if cost[li] >= half:
            continue
        c = 0
        for t in range(indptr[i], indptr[i + 1]):
            lj = labels[indices[t]]
            if _is_candidate(li, lj, dirty, cost, limit):
                c += 1
        per_point[s + 1] = c
    start = np.cumsum(per_point)
    if start[n] == 0:
        return np.empty((0, 2), dtype=np.int64)
    key = np.empty(start[n], dtype=np.int64)
    for s in prange(n):
        if per_point[s + 1] == 0:
            continue
        i = points[s]
        li = labels[i]
        c = start[s]
        for t in range(indptr[i], indptr[i + 1]):
            lj = labels[indices[t]]
            if _is_candidate(li, lj, dirty, cost, limit):
                key[c] = min(li, lj) * m + max(li, lj)
                c += 1
    return _pairs_of_keys(key, m)


@njit(cache=True)
def edge_pairs(indptr, indices):
    """All graph edges (i < j), sorted: the region pairs when every point is a region."""
    n = indptr.shape[0] - 1
    count = 0
    for i in range(n):
        for t in range(indptr[i], indptr[i + 1]):
            if indices[t] > i:
                count += 1
    out = np.empty((count, 2), dtype=np.int64)
    c = 0
    for i in range(n):
        for t in range(indptr[i], indptr[i + 1]):
            if indices[t] > i:
                out[c, 0] = i
                out[c, 1] = indices[t]
                c += 1
    return out


# --------------------------------------------------------------------------- heap


@njit(cache=True)
def _less(ck, ca, cb, i, j):
    if ck[i] != ck[j]:
        return ck[i] < ck[j]
    if ca[i] != ca[j]:
        return ca[i] < ca[j]
    return cb[i] < cb[j]


@njit(cache=True)
def _swap(ck, ca, cb, i, j):
    ck[i], ck[j] = ck[j], ck[i]
    ca[i], ca[j] = ca[j], ca[i]
    cb[i], cb[j] = cb[j], cb[i]


@njit(cache=True)
def _sift_up(ck, ca, cb, pos):
    while pos > 0:
        parent = (pos - 1) >> 1
        if _less(ck, ca, cb, pos, parent):
            _swap(ck, ca, cb, pos, parent)
            pos = parent
        else:
            break


@njit(cache=True)
def _sift_down(ck, ca, cb, size, pos):
    while True:
        left = 2 * pos + 1
        if left >= size:
            break
        best = left
        right = left + 1
        if right < size and _less(ck, ca, cb, right, left):
            best = right
        if _less(ck, ca, cb, best, pos):
            _swap(ck, ca, cb, best, pos)
            pos = best
        else:
            break


# --------------------------------------------------------------------------- flood


@njit(cache=True)
def _push_neighbours(indptr, indices, normals, seed_normals, labels, p, r, ck, ca, cb, size):
    """Queue every unlabelled neighbour j of point p for region r (key |n_j - N_r|^2);
    the queue arrays double when full. Returns the (possibly new) arrays and size."""
    for t in range(indptr[p], indptr[p + 1]):
        j = indices[t]
        if labels[j] >= 0:
            continue
        if size == ck.shape[0]:
            cap = 2 * size
            ck2 = np.empty(cap, dtype=np.float64)
            ca2 = np.empty(cap, dtype=np.int64)
            cb2 = np.empty(cap, dtype=np.int64)
            ck2[:size] = ck[:size]
            ca2[:size] = ca[:size]
            cb2[:size] = cb[:size]
            ck, ca, cb = ck2, ca2, cb2
        d0 = normals[j, 0] - seed_normals[r, 0]
        d1 = normals[j, 1] - seed_normals[r, 1]
        d2 = normals[j, 2] - seed_normals[r, 2]
        ck[size] = d0 * d0 + d1 * d1 + d2 * d2
        ca[size] = j
        cb[size] = r
        size += 1
        _sift_up(ck, ca, cb, size - 1)
    return ck, ca, cb, size


@njit(cache=True)
def flood(indptr, indices, normals, seeds, seed_normals):
    """Priority-queue flood of thesis 4.2.1/4.2.2 from ``seeds`` (region r = seeds[r]).

    Queue key |n_j - N_r|^2; ties by smaller point index, then smaller region.
    Points the flood cannot reach keep label -1.
    """
    n = normals.shape[0]
    labels = np.full(n, -1, dtype=np.int64)
    cap = max(16, 2 * seeds.shape[0] + 16)
    ck = np.empty(cap, dtype=np.float64)
    ca = np.empty(cap, dtype=np.int64)
    cb = np.empty(cap, dtype=np.int64)
    size = 0
    for r in range(seeds.shape[0]):
        labels[seeds[r]] = r
    for r in range(seeds.shape[0]):
        ck, ca, cb, size = _push_neighbours(
            indptr, indices, normals, seed_normals, labels, seeds[r], r, ck, ca, cb, size
        )
    while size > 0:
        p = ca[0]
        r = cb[0]
        size -= 1
        if size > 0:
            ck[0] = ck[size]
            ca[0] = ca[size]
            cb[0] = cb[size]
            _sift_down(ck, ca, cb, size, 0)
        if labels[p] >= 0:
            continue
        labels[p] = r
        ck, ca, cb, size = _push_neighbours(
            indptr, indices, normals, seed_normals, labels, p, r, ck, ca, cb, size
        )
    return labels


# --------------------------------------------------------------------------- switch


@njit(cache=True)
def boundary_points(indptr, indices, labels):
    """Points with at least one neighbour in another region, increasing."""
    return np.flatnonzero(foreign_counts(indptr, indices, labels) > 0)


@njit(cache=True, parallel=True)
def foreign_counts(indptr, indices, labels):
    """Number of graph neighbours of every point that lie in another region."""
    n = labels.shape[0]
    out = np.zeros(n, dtype=np.int64)
    for i in prange(n):
        li = labels[i]
        c = 0
        for t in range(indptr[i], indptr[i + 1]):
            if labels[indices[t]] != li:
                c += 1
        out[i] = c
    return out


@njit(cache=True, parallel=True)
def recount_foreign(indptr, indices, labels, foreign, points):
    """`foreign_counts` recomputed in place for ``points`` only."""
    for s in prange(points.shape[0]):
        i = points[s]
        li = labels[i]
        c = 0
        for t in range(indptr[i], indptr[i + 1]):
            if labels[indices[t]] != li:
                c += 1
        foreign[i] = c


@njit(cache=True, parallel=True)
def touched_points(indptr, indices, labels, foreign, dirty):
    """Boundary points next to a region flagged in ``dirty`` (increasing).

    A boundary point (``foreign[i] > 0``) is returned when its own region or the
    region of one of its graph neighbours is dirty. With ``dirty`` the regions
    whose W, S changed since a step last looked at every point, the points not
    returned see the same proxies and the same neighbouring labels as then, so a
    switch or merge step restricted to the returned points decides exactly as a
    full scan would. (Parallel: threads may store the same 1 into a flag twice,
    which is harmless.)
    """
    n = labels.shape[0]
    mark = np.zeros(n, dtype=np.uint8)
    for i in prange(n):
        if foreign[i] == 0 or not dirty[labels[i]]:
            continue
        mark[i] = 1
        li = labels[i]
        for t in range(indptr[i], indptr[i + 1]):
            j = indices[t]
            if labels[j] != li:
                mark[j] = 1
    return np.flatnonzero(mark)


@njit(cache=True)
def _compact_moves(target):
    """Positions with target >= 0 (increasing) and their targets."""
    count = 0
    for s in range(target.shape[0]):
        if target[s] >= 0:
            count += 1
    pos = np.empty(count, dtype=np.int64)
    new = np.empty(count, dtype=np.int64)
    c = 0
    for s in range(target.shape[0]):
        if target[s] >= 0:
            pos[c] = s
            new[c] = target[s]
            c += 1
    return pos, new


@njit(cache=True, parallel=True)
def batch_switch(
    indptr, indices, normals, weights, labels, proxy_normals, foreign, min_gain, candidates
):
    """Every boundary point moves to the neighbouring region whose proxy fits best.

    With the proxy normals fixed the energy is a sum of per-point terms
    w_i |n_i - N_l|^2 = 2 w_i (1 - n_i . N_l), so all strictly improving moves can
    be applied at once (GUIDE B2). Only the ``candidates`` (increasing point
    indices) with ``foreign[i] > 0`` (a neighbour in another region) are looked
    at; the decisions are independent, so they run in parallel. Ties go to the
    smaller region label. Returns the moved points (increasing) and their new
    labels; ``labels`` is not changed.
    """
    nc = candidates.shape[0]
    target = np.full(nc, -1, dtype=np.int64)
    for s in prange(nc):
        i = candidates[s]
        if foreign[i] == 0:
            continue
        li = labels[i]
        cur = (
            normals[i, 0] * proxy_normals[li, 0]
            + normals[i, 1] * proxy_normals[li, 1]
            + normals[i, 2] * proxy_normals[li, 2]
        )
        best = cur
        best_label = li
        for t in range(indptr[i], indptr[i + 1]):
            h = labels[indices[t]]
            if h == li:
                continue
            d = (
                normals[i, 0] * proxy_normals[h, 0]
                + normals[i, 1] * proxy_normals[h, 1]
                + normals[i, 2] * proxy_normals[h, 2]
            )
            if d > best or (d == best and best_label != li and h < best_label):
                best = d
                best_label = h
        if best_label != li and 2.0 * weights[i] * (best - cur) > min_gain:
            target[s] = best_label
    pos, new = _compact_moves(target)
    return candidates[pos], new


@njit(cache=True, parallel=True)
def batch_switch_bounded(
    indptr, indices, normals, weights, labels, proxy_normals, foreign, min_gain, drift, memo
):
    """`batch_switch` over every boundary point, skipping points proven to stay.

    Gives exactly the moves of `batch_switch` over all boundary points. A point
    that was examined and stayed keeps, in ``memo``, the margin by which it
    stayed: with cur = n_i . N_own and best = max over neighbouring regions of
    n_i . N_h, margin = cur - best. ``drift`` (m,) holds, per region, the summed
    proxy movement sum_t |N_l(t) - N_l(t - 1)| since a reference time; as
    |n . (N(t) - N(t0))| <= that sum's increase, cur can drop and every
    n_i . N_h grow by at most the drift of their regions, so while no label in
    the point's neighbourhood changed and

        margin(t0) - (drift growth of its own region + of its foreign regions) > tol

    the point still stays (it would need best - cur > min_gain / (2 w) >= 0 to
    move) and is skipped. Tighter, as proxies are unit vectors: with
    r = n - N(t0), n . (N(t) - N(t0)) = -|N(t) - N(t0)|^2 / 2 + r . (N(t) - N(t0)),
    so a region whose drift grew by D moves the point's dot product by at most
    rho D + D^2 / 2, rho = max |n - N(t0)| over its own and foreign regions; the
    test is margin - (rho G + G^2 / 2) > tol with G the summed drift growth.
    ``memo`` (N, 6) float64 stores per point: the margin (NaN: must be examined,
    e.g. a neighbour's label changed), the drift sum at t0, the ids of up to 3
    foreign regions (as floats; -1 none; a point next to more regions is always
    examined) and rho. When the bound fails, the point is decided over the
    remembered foreign regions alone (the same cur, best and tie rule as a full
    examination, without reading its neighbours' labels: none of them changed),
    and the memo is refreshed with the values a full examination would store.
    The caller sets column 0 to NaN for moved points and their neighbours, for
    points next to merged regions, and renumbers the stored ids after a merge.
    Returns moved points (increasing) and new labels.
    """
    n = labels.shape[0]
    target = np.full(n, -1, dtype=np.int64)
    for i in prange(n):
        if foreign[i] == 0 or weights[i] <= 0.0:
            continue
        li = labels[i]
        margin = memo[i, 0]
        remembered = margin == margin  # not NaN: try the bound
        if remembered:
            total = drift[li]
            for c in range(2, 5):
                h = np.int64(memo[i, c])
                if h >= 0:
                    total += drift[h]
            grow = total - memo[i, 1]
            if margin - (memo[i, 5] * grow + 0.5 * grow * grow) > 1e-12 * (1.0 + total):
                continue
        cur = _dot_proxy(normals, proxy_normals, i, li)
        best = cur
        best_label = li
        top = -np.inf
        low = cur
        many = False
        if remembered:
            # the bound fails: decide over the remembered foreign regions (no label
            # around the point changed, so they are exactly its foreign regions)
            f0 = np.int64(memo[i, 2])
            f1 = np.int64(memo[i, 3])
            f2 = np.int64(memo[i, 4])
            for h in (f0, f1, f2):
                if h >= 0:
                    d = _dot_proxy(normals, proxy_normals, i, h)
                    best, best_label, top, low = _consider(d, h, li, best, best_label, top, low)
        else:
            f0 = -1
            f1 = -1
            f2 = -1
            for t in range(indptr[i], indptr[i + 1]):
                h = labels[indices[t]]
                if h == li:
                    continue
                if h != f0 and h != f1 and h != f2:
                    if f0 < 0:
                        f0 = h
                    elif f1 < 0:
                        f1 = h
                    elif f2 < 0:
                        f2 = h
                    else:
                        many = True
                d = _dot_proxy(normals, proxy_normals, i, h)
                best, best_label, top, low = _consider(d, h, li, best, best_label, top, low)
        if best_label != li and 2.0 * weights[i] * (best - cur) > min_gain:
            target[i] = best_label
            memo[i, 0] = np.nan
        elif many:
            memo[i, 0] = np.nan
        else:
            total = drift[li]
            if f0 >= 0:
                total += drift[f0]
            if f1 >= 0:
                total += drift[f1]
            if f2 >= 0:
                total += drift[f2]
            memo[i, 0] = cur - top
            memo[i, 1] = total
            memo[i, 2] = f0
            memo[i, 3] = f1
            memo[i, 4] = f2
            memo[i, 5] = np.sqrt(max(2.0 - 2.0 * low, 0.0)) + 1e-12
    return _compact_moves(target)


@njit(cache=True, inline="always")
def _dot_proxy(normals, proxy_normals, i, h):
    """n_i . N_h."""
    return (
        normals[i, 0] * proxy_normals[h, 0]
        + normals[i, 1] * proxy_normals[h, 1]
        + normals[i, 2] * proxy_normals[h, 2]
    )


@njit(cache=True, inline="always")
def _consider(d, h, li, best, best_label, top, low):
    """One foreign region h with n_i . N_h = d: the best label (largest d, ties to
    the smaller label, own region li kept on a tie with it), the largest and the
    smallest d seen."""
    if d > top:
        top = d
    if d < low:
        low = d
    if d > best or (d == best and best_label != li and h < best_label):
        best = d
        best_label = h
    return best, best_label, top, low


@njit(cache=True, parallel=True)
def renumber_memo(memo, remap):
    """Renumber the foreign-region ids of the examined points after a merge
    (rows are independent: parallel)."""
    for i in prange(memo.shape[0]):
        if memo[i, 0] == memo[i, 0]:
            for c in range(2, 5):
                h = np.int64(memo[i, c])
                if h >= 0:
                    memo[i, c] = remap[h]


@njit(cache=True)
def forget_around(indptr, indices, points, memo):
    """Mark ``points`` and their graph neighbours for re-examination (memo NaN)."""
    for s in range(points.shape[0]):
        p = points[s]
        memo[p, 0] = np.nan
        for t in range(indptr[p], indptr[p + 1]):
            memo[indices[t], 0] = np.nan


@njit(cache=True)
def best_single_move(indptr, indices, normals, weights, labels, proxy_normals, foreign):
    """The thesis' switch (4.3.2): the one reassignment that lowers the energy most.

    Scans the boundary points (``foreign[i] > 0``). Returns (point, new_label,
    gain); gain <= 0 means no improving move. Ties go to the smaller point index,
    then the smaller label.
    """
    best_gain = 0.0
    best_point = -1
    best_label = -1
    for i in range(labels.shape[0]):
        if foreign[i] == 0:
            continue
        li = labels[i]
        cur = (
            normals[i, 0] * proxy_normals[li, 0]
            + normals[i, 1] * proxy_normals[li, 1]
            + normals[i, 2] * proxy_normals[li, 2]
        )
        for t in range(indptr[i], indptr[i + 1]):
            h = labels[indices[t]]
            if h == li:
                continue
            d = (
                normals[i, 0] * proxy_normals[h, 0]
                + normals[i, 1] * proxy_normals[h, 1]
                + normals[i, 2] * proxy_normals[h, 2]
            )
            gain = 2.0 * weights[i] * (d - cur)
            if gain > best_gain or (
                gain == best_gain and gain > 0.0 and best_point == i and h < best_label
            ):
                best_gain = gain
                best_point = i
                best_label = h
    return best_point, best_label, best_gain


@njit(cache=True)
def apply_moves(indptr, indices, labels, wsum, ssum, counts, foreign, weights, wn, moved, new):
    """Move points to new regions, updating W, S, counts and the foreign-neighbour
    counts incrementally (all in place)."""
    for t in range(moved.shape[0]):
        p = moved[t]
        a = labels[p]
        b = new[t]
        if a == b:
            continue
        wsum[a] -= weights[p]
        wsum[b] += weights[p]
        counts[a] -= 1
        counts[b] += 1
        for d in range(3):
            ssum[a, d] -= wn[p, d]
            ssum[b, d] += wn[p, d]
        c = 0
        for u in range(indptr[p], indptr[p + 1]):
            q = indices[u]
            lq = labels[q]
            if lq == a:
                foreign[q] += 1
            elif lq == b:
                foreign[q] -= 1
            if lq != b:
                c += 1
        foreign[p] = c
        labels[p] = b


@njit(cache=True)
def best_points(labels, m, normals, proxy_normals):
    """Point of every region with least |n_j - N_i|^2 (ties: smaller index)."""
    best = np.full(m, -1, dtype=np.int64)
    best_dev = np.full(m, np.inf)
    for i in range(labels.shape[0]):
        r = labels[i]
        d0 = normals[i, 0] - proxy_normals[r, 0]
        d1 = normals[i, 1] - proxy_normals[r, 1]
        d2 = normals[i, 2] - proxy_normals[r, 2]
        dev = d0 * d0 + d1 * d1 + d2 * d2
        if dev < best_dev[r]:
            best_dev[r] = dev
            best[r] = i
    return best


# --------------------------------------------------------------------------- merge


@njit(cache=True)
def _union_cost(ws, a, b):
    """L21 (cost), W and |S| of the union of regions a, b; rows of ``ws`` are
    (W, Sx, Sy, Sz), so a region's sums share one cache line."""
    sx = ws[a, 1] + ws[b, 1]
    sy = ws[a, 2] + ws[b, 2]
    sz = ws[a, 3] + ws[b, 3]
    w = ws[a, 0] + ws[b, 0]
    s = np.sqrt(sx * sx + sy * sy + sz * sz)
    cost = 2.0 * (w - s)
    if cost < 0.0:
        cost = 0.0
    return cost, w, s


#: how many stream entries ahead `greedy_merge` prefetches the union-find parents
#: and the region sums of a pair (1M-point scene: the merge 1.3x faster; 24 and
#: 12 were no better)
_AHEAD_PARENT = 16
_AHEAD_SUMS = 8

#: arity of the merge heap; its entries are 16 bytes, so one node's children
#: fill one 64-byte cache line when the array is aligned (see `_heap_base`)
_ARITY = 4


@njit(cache=True)
def _sift_up2(heap, base, pos):
    """Heap entries are rows (key bits, pair code) of one int64 array: a key is a
    non-negative double, whose IEEE bits order as int64 as the values do, so an
    entry is one 16-byte record compared lexicographically. Logical node ``pos``
    is row ``base + pos``."""
    key = heap[base + pos, 0]
    pair = heap[base + pos, 1]
    while pos > 0:
        parent = (pos - 1) // _ARITY
        pk = heap[base + parent, 0]
        if key < pk or (key == pk and pair < heap[base + parent, 1]):
            heap[base + pos, 0] = pk
            heap[base + pos, 1] = heap[base + parent, 1]
            pos = parent
        else:
            break
    heap[base + pos, 0] = key
    heap[base + pos, 1] = pair


@njit(cache=True)
def _sift_down2(heap, base, size, pos):
    """d-ary heap: children of pos are d pos + 1 .. d pos + d (shallow, and one
    cache line holds them all); the grandchildren's lines are prefetched one
    level ahead."""
    key = heap[base + pos, 0]
    pair = heap[base + pos, 1]
    while True:
        first = _ARITY * pos + 1
        if first >= size:
            break
        grand = _ARITY * first + 1
        if grand + _ARITY * (_ARITY - 1) < size:
            # the children's children: one line each, needed on the next level
            for c in range(_ARITY):
                _prefetch(heap, base + grand + _ARITY * c)
        child = first
        ckey = heap[base + first, 0]
        cpair = heap[base + first, 1]
        last = min(first + _ARITY, size)
        for c in range(first + 1, last):
            k = heap[base + c, 0]
            if k < ckey or (k == ckey and heap[base + c, 1] < cpair):
                child = c
                ckey = k
                cpair = heap[base + c, 1]
        if ckey < key or (ckey == key and cpair < pair):
            heap[base + pos, 0] = ckey
            heap[base + pos, 1] = cpair
            pos = child
        else:
            break
    heap[base + pos, 0] = key
    heap[base + pos, 1] = pair


@njit(cache=True)
def _heap_base(heap):
    """Row of logical node 0 such that the children d i + 1 .. d i + d of every
    node start on a 64-byte boundary (rows are 16 bytes)."""
    lead = (heap.ctypes.data // 16) % 4  # rows before the first aligned row
    return (4 - lead) % 4 + (_ARITY - 1)


@njit(cache=True, parallel=True)
def _pair_costs(pairs, ws, eta, min_cos, use_angle):
    """Union cost (+0.0 for -0.0: keys compare by their bits) of every pair and
    whether the union is acceptable (`greedy_merge`'s initial entries; parallel,
    the region sums of the pairs a few rows ahead prefetched)."""
    n = pairs.shape[0]
    costs = np.empty(n)
    keep = np.empty(n, dtype=np.bool_)
    for e in prange(n):
        if e + _AHEAD_PARENT < n:
            _prefetch(ws, pairs[e + _AHEAD_PARENT, 0])
            _prefetch(ws, pairs[e + _AHEAD_PARENT, 1])
        cost, w, s = _union_cost(ws, pairs[e, 0], pairs[e, 1])
        keep[e] = (s >= min_cos * w) if use_angle else (cost < eta)
        costs[e] = cost + 0.0
    return costs, keep


@njit(cache=True)
def _sort_entries(keys, codes):
    """Key bits and codes sorted stably by key: ``stable_argsort`` and two gathers
    in one LSD radix sort that carries the code (no random gather afterwards).

    ``keys`` are non-negative doubles without -0.0, whose int64 bits order as
    the values do; passes whose digit is the same for every key are skipped.
    Same output as ``keys[order].view(np.int64), codes[order]`` with ``order =
    stable_argsort(keys)``.
    """
    n = keys.shape[0]
    k, v = radix_sort_payload(
        keys.view(np.uint64).copy(),
        codes.copy(),
        np.empty(n, dtype=np.uint64),
        np.empty(n, dtype=np.int64),
    )
    return k.view(np.int64), v


@njit(cache=True)
def _less_entry(ka, pa, kb, pb):
    return ka < kb or (ka == kb and pa < pb)


@njit(cache=True)
def _find32(parent, i):
    while parent[i] != i:  # path halving
        parent[i] = parent[parent[i]]
        i = parent[i]
    return i


@njit(cache=True)
def greedy_merge(pairs, wsum, ssum, eta, min_cos, use_angle):
    """Cheapest-union-first merging on the region adjacency graph (4.3.3 b).

    ``pairs`` (E, 2) are adjacent regions; ``wsum`` (m,) and ``ssum`` (m, 3) the
    per-region sums W = sum w_j and S = sum w_j n_j, so the L21 of a union is
    2 (W_a + W_b - |S_a + S_b|) in O(1) (GUIDE B2). Key: that L21, ties by
    (a, b). A union is accepted when its L21 < eta, or, with ``use_angle``, when
    its mean normal cosine |S|/W >= ``min_cos``.

    Entries are evaluated lazily: L21 only grows with the point set, so a key
    pushed earlier is a lower bound of the pair's current cost; a popped pair
    whose current cost exceeds the next key is pushed back with the current
    cost, otherwise it is the cheapest and is merged, so in eta mode the order is
    exactly cheapest-first. The initial entries are sorted once by (key, pair)
    and read as a stream; pushed-back entries go to a 4-ary heap, and every pop
    takes the smaller of the stream's head and the heap's top. Returns the root
    of every region (union-find, the smaller id survives) and the number of
    merges.

    Internally a pair (a < b) is coded (a << 32) | b (same order as (a, b)) and
    a key by the int64 bits of the (non-negative) double, so an entry is two
    int64 compared lexicographically; fewer than 2**31 regions.

    The loop is bound by memory latency (from 1M singleton regions: about 7.5M
    pops, each reading scattered parents, region sums, versions, dedupe slots
    and heap nodes that depend on one another), so the rows the next stream
    entries and the next heap top will read are prefetched (`_prefetch`), and
    the sift-down prefetches a level ahead. Prefetches are hints only: every
    decision, and so the result, is that of the plain loop.
    """
    m = wsum.shape[0]
    if m >= 2**31 - 1:
        raise ValueError("greedy_merge: at most 2**31 - 2 regions")
    # 32-byte rows starting on a 32-byte boundary: a row never straddles two
    # cache lines
    ws_buf = np.empty(4 * m + 4)
    ws_lead = ((32 - ws_buf.ctypes.data % 32) % 32) // 8
    ws = ws_buf[ws_lead : ws_lead + 4 * m].reshape(m, 4)
    ws[:, 0] = wsum
    ws[:, 1:] = ssum
    parent = np.arange(m).astype(np.int32)
    low = np.int64(0xFFFFFFFF)
    n_init = 0
    k0 = np.empty(pairs.shape[0], dtype=np.float64)
    p0 = np.empty(pairs.shape[0], dtype=np.int64)
    costs, keep = _pair_costs(pairs, ws, eta, min_cos, use_angle)
    for e in range(pairs.shape[0]):
        if keep[e]:
            a = pairs[e, 0]
            b = pairs[e, 1]
            k0[n_init] = costs[e]
            p0[n_init] = (min(a, b) << 32) | max(a, b)
            n_init += 1
    k0 = k0[:n_init]
    p0 = p0[:n_init]
    increasing = True
    for e in range(1, n_init):
        if p0[e] <= p0[e - 1]:
            increasing = False
            break
    if not increasing:
        by_pair = np.argsort(p0, kind="mergesort")
        k0 = k0[by_pair]
        p0 = p0[by_pair]
    ks, ps = _sort_entries(k0, p0)  # stable: ties stay sorted by pair
    head = 0
    hot_cap = 4096
    heap = np.empty((hot_cap + 8, 2), dtype=np.int64)
    base = _heap_base(heap)
    size = 0
    n_merges = 0
    bits = np.empty(1, dtype=np.float64)
    bits_i = bits.view(np.int64)
    # duplicates: many point edges map to the same region pair; remember the
    # region versions each pair was last pushed with and drop stale copies
    version = np.zeros(m, dtype=np.int64)
    # direct-mapped table code -> stamp of the last push (a collision only costs
    # an extra push, never a wrong drop: the code is compared too); a slot's
    # code and stamp share a row
    n_slots = 1024
    while n_slots < pairs.shape[0]:
        n_slots *= 2
    mask = n_slots - 1
    slots = np.full((n_slots, 2), -1, dtype=np.int64)
    ahead_parent = 0  # stream entries whose parents were prefetched
    ahead_sums = 0  # stream entries whose (probable) roots' sums were prefetched
    while True:
        if size == 0 and head == n_init:
            break
        # prefetch for the stream entries popped soon: their parents 16 entries
        # ahead; 8 ahead the sums, versions and dedupe slot of their probable
        # roots (two steps up; a wrong guess only wastes the prefetch)
        lim = min(head + _AHEAD_PARENT, n_init)
        while ahead_parent < lim:
            e = ps[ahead_parent]
            _prefetch(parent, e >> 32)
            _prefetch(parent, e & low)
            ahead_parent += 1
        lim = min(head + _AHEAD_SUMS, n_init)
        while ahead_sums < lim:
            e = ps[ahead_sums]
            xa = parent[parent[e >> 32]]
            xb = parent[parent[e & low]]
            _prefetch(ws, xa)
            _prefetch(ws, xb)
            xlo = np.int64(min(xa, xb))
            xhi = np.int64(max(xa, xb))
            xcode = (xlo << 32) | xhi
            _prefetch(version, xlo)
            _prefetch(version, xhi)
            _prefetch(slots, ((xcode * 0x5851F42D4C957F2D) >> 20) & mask)
            ahead_sums += 1
        if size > 0 and (
            head == n_init or _less_entry(heap[base, 0], heap[base, 1], ks[head], ps[head])
        ):
            key = heap[base, 0]
            pair = heap[base, 1]
            size -= 1
            if size > 0:
                heap[base, 0] = heap[base + size, 0]
                heap[base, 1] = heap[base + size, 1]
                _sift_down2(heap, base, size, 0)
                # the next top's regions (heap codes are roots when pushed)
                e = heap[base, 1]
                _prefetch(parent, e >> 32)
                _prefetch(parent, e & low)
                _prefetch(ws, e >> 32)
                _prefetch(ws, e & low)
                _prefetch(version, e >> 32)
                _prefetch(version, e & low)
                _prefetch(slots, ((e * 0x5851F42D4C957F2D) >> 20) & mask)
        else:
            key = ks[head]
            pair = ps[head]
            head += 1
        ra = _find32(parent, pair >> 32)
        rb = _find32(parent, pair & low)
        if ra == rb:
            continue
        cost, w, s = _union_cost(ws, ra, rb)
        ok = (s >= min_cos * w) if use_angle else (cost < eta)
        if not ok:
            continue
        lo = np.int64(min(ra, rb))
        hi = np.int64(max(ra, rb))
        code = (lo << 32) | hi
        bits[0] = cost + 0.0
        ckey = bits_i[0]
        if ckey > key:
            still_min = True
            if size > 0 and not _less_entry(ckey, code, heap[base, 0], heap[base, 1]):
                still_min = False
            if head < n_init and not _less_entry(ckey, code, ks[head], ps[head]):
                still_min = False
            if not still_min:
                # stale lower bound: push back with the current cost, unless an
                # entry computed from the same regions is already queued
                stamp = (version[lo] << 32) | version[hi]
                slot = ((code * 0x5851F42D4C957F2D) >> 20) & mask
                if slots[slot, 0] == code and slots[slot, 1] == stamp:
                    continue
                slots[slot, 0] = code
                slots[slot, 1] = stamp
                if size == hot_cap:
                    hot_cap *= 2
                    heap2 = np.empty((hot_cap + 8, 2), dtype=np.int64)
                    base2 = _heap_base(heap2)
                    heap2[base2 : base2 + size] = heap[base : base + size]
                    heap = heap2
                    base = base2
                heap[base + size, 0] = ckey
                heap[base + size, 1] = code
                size += 1
                _sift_up2(heap, base, size - 1)
                continue
        parent[hi] = lo
        version[lo] += 1
        ws[lo, 0] = w
        ws[lo, 1] += ws[hi, 1]
        ws[lo, 2] += ws[hi, 2]
        ws[lo, 3] += ws[hi, 3]
        n_merges += 1
    roots = np.empty(m, dtype=np.int64)
    for i in range(m):
        roots[i] = _find32(parent, i)
    return roots, n_merges


# --------------------------------------------------------------------------- region growing


@njit(cache=True)
def region_growing(nbr, normals, curvature, order, cos_threshold, curvature_threshold):
    """Rabbani et al. (2006) smooth region growing as PCL's ``RegionGrowing``.

    ``nbr`` (N, k) directed k-NN table (column 0 the point itself), ``order`` the
    points sorted by increasing curvature (ties by index). A neighbour joins when
    |n_current . n_neighbour| >= cos_threshold; it becomes a further seed when its
    curvature is <= curvature_threshold. Returns raw region labels (every point
    labelled) in growth order.
    """
    n = normals.shape[0]
    labels = np.full(n, -1, dtype=np.int64)
    queue = np.empty(n, dtype=np.int64)
    region = 0
    for s in range(order.shape[0]):
        start = order[s]
        if labels[start] >= 0:
            continue
        labels[start] = region
        head = 0
        tail = 0
        queue[tail] = start
        tail += 1
        while head < tail:
            cur = queue[head]
            head += 1
            for t in range(nbr.shape[1]):
                j = nbr[cur, t]
                if j < 0 or labels[j] >= 0:
                    continue
                d = (
                    normals[cur, 0] * normals[j, 0]
                    + normals[cur, 1] * normals[j, 1]
                    + normals[cur, 2] * normals[j, 2]
                )
                if abs(d) < cos_threshold:
                    continue
                labels[j] = region
                if curvature[j] <= curvature_threshold:
                    queue[tail] = j
                    tail += 1
        region += 1
    return labels
