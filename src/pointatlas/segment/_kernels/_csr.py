"""The graph and the labels on it: symmetric CSR adjacency, label numbering,
connected pieces, region pairs and boundary bookkeeping.

Graphs are symmetric CSR structures ``(indptr, indices)`` without self loops, rows
sorted increasingly. A point is a boundary point when one of its graph neighbours
lies in another region (``foreign`` counts those neighbours).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from ..._core._sort import sorted_key_runs
from ..._core.kernels import find_root, union_min


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
def canonical_labels(labels):
    """Renumber labels 0..m-1 by first occurrence; returns (new_labels, m)."""
    n = labels.shape[0]
    top = 0
    for i in range(n):
        if labels[i] > top:
            top = labels[i]
    remap = np.empty(top + 1, dtype=np.int64)  # np.empty + a loop: one spelling less
    for lab in range(top + 1):
        remap[lab] = -1
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
    parent = np.empty(n, dtype=np.int64)  # np.empty + a loop: one spelling less
    for i in range(n):
        parent[i] = i
    for i in range(n):
        for t in range(indptr[i], indptr[i + 1]):
            j = indices[t]
            if j > i and labels[j] == labels[i]:
                union_min(parent, i, j)
    roots = np.empty(n, dtype=np.int64)
    for i in range(n):
        roots[i] = find_root(parent, i)
    return canonical_labels(roots)


def pairs_of_keys(key, m):
    """Distinct pair keys a * m + b (>= 0) as sorted (a, b) rows; ``key`` (int64) is
    overwritten. The shared radix sort and run mask (`sorted_key_runs`, which the
    grid k-NN uses for its cells) called from Python: numba's ``np.unique`` sort
    compiles for seconds, its ``view`` for a tenth of a second per dtype pair."""
    srt, _, first = sorted_key_runs(key)
    distinct = srt[first]
    out = np.empty((distinct.shape[0], 2), dtype=np.int64)
    if distinct.shape[0]:
        np.floor_divide(distinct, m, out=out[:, 0])
        np.remainder(distinct, m, out=out[:, 1])
    return out


@njit(cache=True)
def _region_pair_keys(indptr, indices, labels, subset):
    """The keys li * m + lj (li < lj, m = largest label + 1; repeats kept) of the
    edges at the points of ``subset`` between regions, and m (`region_pairs`)."""
    count = 0
    for s in range(subset.shape[0]):
        i = subset[s]
        for t in range(indptr[i], indptr[i + 1]):
            if labels[indices[t]] > labels[i]:
                count += 1
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
    return key, m


def region_pairs(indptr, indices, labels, subset):
    """Distinct region pairs (a < b) joined by a graph edge at a point of ``subset``.

    With ``subset`` the boundary points (or all points) that is the region
    adjacency of Remark 6. Sorted by (a, b).
    """
    key, m = _region_pair_keys(indptr, indices, labels, subset)
    return pairs_of_keys(key, m)


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


@njit(cache=True, inline="always")
def _foreign_count(indptr, indices, labels, i):
    """Number of graph neighbours of point i that lie in another region."""
    li = labels[i]
    c = 0
    for t in range(indptr[i], indptr[i + 1]):
        if labels[indices[t]] != li:
            c += 1
    return c


@njit(cache=True)
def foreign_counts(indptr, indices, labels):
    """Number of graph neighbours of every point that lie in another region."""
    n = labels.shape[0]
    out = np.zeros(n, dtype=np.int64)
    for i in range(n):
        out[i] = _foreign_count(indptr, indices, labels, i)
    return out


@njit(cache=True)
def recount_foreign(indptr, indices, labels, foreign, points):
    """`foreign_counts` recomputed in place for ``points`` only."""
    for s in range(points.shape[0]):
        i = points[s]
        foreign[i] = _foreign_count(indptr, indices, labels, i)


def boundary_points(indptr, indices, labels):
    """Points with at least one neighbour in another region, increasing."""
    return np.flatnonzero(foreign_counts(indptr, indices, labels) > 0)


def touched_points(indptr, indices, labels, foreign, dirty):
    """Boundary points next to a region flagged in ``dirty`` (increasing).

    A boundary point (``foreign[i] > 0``) is returned when its own region or the
    region of one of its graph neighbours is dirty. With ``dirty`` the regions
    whose W, S changed since a step last looked at every point, the points not
    returned see the same proxies and the same neighbouring labels as then, so a
    switch or merge step restricted to the returned points decides exactly as a
    full scan would. The points are marked by a kernel and listed by numpy's
    ``flatnonzero`` (numba's compiles for half a CPU-second).
    """
    mark = np.zeros(labels.shape[0], dtype=np.bool_)
    _mark_touched(indptr, indices, labels, foreign, dirty, mark)
    return np.flatnonzero(mark)


@njit(cache=True)
def _mark_touched(indptr, indices, labels, foreign, dirty, mark):
    """`touched_points` as a mask: sets ``mark`` (all False) at the points it returns."""
    n = labels.shape[0]
    for i in range(n):
        if foreign[i] == 0 or not dirty[labels[i]]:
            continue
        mark[i] = True
        li = labels[i]
        for t in range(indptr[i], indptr[i + 1]):
            j = indices[t]
            if labels[j] != li:
                mark[j] = True


@njit(cache=True)
def farthest_neighbor_distances(indptr, indices, points):
    """Per point, the distance to its farthest graph neighbour (0.0 without one):
    sqrt((dx^2 + dy^2) + dz^2) of q - p, the sum `_sums.row_norms` forms."""
    n = indptr.shape[0] - 1
    out = np.empty(n)
    for i in range(n):
        far = 0.0
        for e in range(indptr[i], indptr[i + 1]):
            j = indices[e]
            dx = points[j, 0] - points[i, 0]
            dy = points[j, 1] - points[i, 1]
            dz = points[j, 2] - points[i, 2]
            d = np.sqrt(dx * dx + dy * dy + dz * dz)
            if d > far:
                far = d
        out[i] = far
    return out
