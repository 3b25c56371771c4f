"""Minimum spanning forest with sign parities (Filter-Kruskal, numba).

The orientation step propagates normal signs along this forest. Validated input
assumed. The tests compare the kept edges with scipy's ``minimum_spanning_tree``.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from ..._core._sort import radix_sort_payload

__all__ = ["spanning_forest_kernel"]

#: Filter-Kruskal: each stage sorts this share of the remaining edges, the lightest
#: (0.2-0.3 work best on a 10^6-point scene; `benchmarks/bench_normals.py`)...
_LIGHT_SHARE = 0.2
#: ... until at most this many remain, which are sorted in one go
_FILTER_MIN = 100_000
#: size of the strided sample of the remaining edge keys that gives a stage's threshold
_SAMPLE = 4096
#: from this many nodes on, payloads hold edge positions, not packed edge ends
_WIDE_NODES = 2**30
_SIGN = np.uint64(1) << np.uint64(63)
_LOW31 = np.uint64(0x7FFFFFFF)


@njit(cache=True)
def _find(link, x):
    """Root of x and the parity of x's path to it, in a union-find whose entries
    are ``parent << 1 | parity to the parent`` (roots: ``x << 1``); path halving.
    """
    acc = 0
    while True:
        v = link[x]
        px = v >> 1
        if px == x:
            return x, acc
        w = link[px]
        grand = w >> 1
        f = (v ^ w) & 1  # parity x -> grandparent
        link[x] = (grand << 1) | f
        acc ^= f
        x = grand


@njit(cache=True)
def _edge(p, rows, cols, opposed, wide):
    """Ends and parity of the edge in payload ``p``: ``a << 32 | b << 1 | parity``,
    or (``wide``) the edge's position in ``cols``."""
    if wide:
        e = np.int64(p)
        return rows[e], cols[e], np.int64(opposed[e])
    return np.int64(p >> np.uint64(32)), np.int64((p >> np.uint64(1)) & _LOW31), np.int64(p & 1)


@njit(cache=True)
def _float_key(b):
    """Unsigned key, in the order of the floats, of the float64 bit pattern ``b``."""
    if b == _SIGN:
        b = np.uint64(0)  # -0.0 ties with +0.0
    return ~b if b & _SIGN else b | _SIGN


@njit(cache=True)
def _quantile_key(sample, share):
    """The ``share`` quantile of a sample of keys (sorted in place)."""
    sample.sort()
    return sample[min(int(share * sample.shape[0]), sample.shape[0] - 1)]


@njit(cache=True)
def _forest_edges(indptr, cols, weights, opposed, link, wide, light_share, filter_min, work):
    """Kruskal's minimum spanning forest in stable weight order, with parities.

    Filter-Kruskal (Osipov, Sanders, Singler 2009): a stage takes the remaining
    edges up to a sampled weight quantile (all once at most ``filter_min``
    remain), sorts them and runs Kruskal; of the heavier ones only those whose
    ends are still in different trees go on. A dropped edge would have closed a
    cycle, so the kept edges are Kruskal's over all edges in (weight, position)
    order: the ones scipy keeps. ``link``: ``2 * arange(n)``, int32 or int64
    (the id width); on return every node's entry leads to its tree's root, and
    the parities along the way add up to the parity of ``opposed`` edges on its
    tree path to the root. ``work``: scratch space of shape (6, E), uint64.
    Returns the kept edges' ends (in Kruskal's order) and their number.
    """
    n = indptr.shape[0] - 1
    m = cols.shape[0]
    rows = np.empty(m if wide else 0, dtype=np.int64)
    bits = weights.view(np.uint64)
    keys = work[0]  # heavy edges, in position order
    payload = work[1]
    light_keys = work[2]  # the stage's edges, in position order
    light_payload = work[3]
    # keys and payloads of every edge, in position order
    k = 0
    for i in range(n):
        for e in range(indptr[i], indptr[i + 1]):
            if wide:
                rows[e] = i
                p = np.uint64(e)
            else:
                p = (
                    (np.uint64(i) << np.uint64(32))
                    | (np.uint64(cols[e]) << np.uint64(1))
                    | np.uint64(opposed[e])
                )
            keys[k] = _float_key(bits[e])
            payload[k] = p
            k += 1
    n_cand = m
    kept_a = np.empty(max(n - 1, 0), dtype=np.int64)
    kept_b = np.empty(max(n - 1, 0), dtype=np.int64)
    n_kept = 0
    while n_cand > 0:
        threshold = ~np.uint64(0)
        if n_cand > filter_min:
            step = max(n_cand // _SAMPLE, 1)
            sample = np.empty((n_cand + step - 1) // step, dtype=np.uint64)
            for s in range(sample.shape[0]):
                sample[s] = keys[s * step]
            threshold = _quantile_key(sample, light_share)
        # stable partition (branch-free): light edges to the side arrays, heavy in place
        n_light = 0
        n_heavy = 0
        for s in range(n_cand):
            key = keys[s]
            p = payload[s]
            is_light = key <= threshold
            light_keys[n_light] = key
            light_payload[n_light] = p
            keys[n_heavy] = key
            payload[n_heavy] = p
            n_light += is_light
            n_heavy += 1 - is_light
        _, ordered = radix_sort_payload(
            light_keys[:n_light], light_payload[:n_light], work[4, :n_light], work[5, :n_light]
        )
        for s in range(n_light):
            if n_kept >= n - 1:
                break
            a, b, parity = _edge(ordered[s], rows, cols, opposed, wide)
            ra, fa = _find(link, a)
            rb, fb = _find(link, b)
            if ra == rb:
                continue
            if ra < rb:  # link by index
                ra, rb = rb, ra
            link[rb] = (ra << 1) | (fa ^ fb ^ parity)
            kept_a[n_kept] = a
            kept_b[n_kept] = b
            n_kept += 1
        if n_heavy == 0 or n_kept >= n - 1:
            break
        for v in range(n):  # point every node at its root
            r, f = _find(link, v)
            link[v] = (r << 1) | f
        n_cand = 0
        for s in range(n_heavy):  # filter: keep the edges between different trees
            p = payload[s]
            a, b, _ = _edge(p, rows, cols, opposed, wide)
            keys[n_cand] = keys[s]
            payload[n_cand] = p
            n_cand += (link[a] >> 1) != (link[b] >> 1)
    return kept_a, kept_b, n_kept


@njit(cache=True)
def _forest_labels(link):
    """Tree of every node (numbered by smallest member) and its path parity."""
    n = link.shape[0]
    labels = np.empty(n, dtype=np.int64)
    parity = np.empty(n, dtype=np.uint8)
    comp_of_root = np.full(n, -1, dtype=np.int64)
    n_comp = 0
    for i in range(n):
        r, f = _find(link, i)
        parity[i] = f
        if comp_of_root[r] < 0:
            comp_of_root[r] = n_comp
            n_comp += 1
        labels[i] = comp_of_root[r]
    return labels, n_comp, parity


@njit(cache=True)
def spanning_forest_kernel(indptr, cols, weights, opposed, work):
    """Minimum spanning forest (Kruskal, stable weight order) and tree parities.

    Parameters
    ----------
    indptr, cols : ndarray of int64
        CSR graph, each undirected edge stored once (as `riemannian_graph_kernel`).
    weights : ndarray of shape (E,), float64
        Edge weights, no NaN. Ties are broken by position in ``cols`` as by a
        stable sort: the order scipy's ``minimum_spanning_tree`` uses, so the
        same edges are kept (for distinct (weight, position) keys the minimum
        spanning forest is unique).
    opposed : ndarray of shape (E,), uint8
        1 where the edge's ends have opposed normals (n_i . n_j < 0), else 0.
    work : ndarray of shape (6, E), uint64
        Scratch space. Allocated by numpy, whose large arrays get huge pages:
        their first touch is several times cheaper than that of numba's.

    Returns
    -------
    kept_a, kept_b : ndarray of shape (K,), int64
        Ends of the forest's edges, in Kruskal's order.
    labels : ndarray of shape (N,), int64
        Tree of every node, numbered by smallest member index.
    n_comp : int
        Number of trees.
    parity : ndarray of shape (N,), uint8
        Parity of the number of opposed edges on the tree path from the node to
        a fixed node of its tree: the tree path between i and j crosses an odd
        number of them iff parity[i] != parity[j]. Breadth-first propagation
        from any root r (flip n_j when n_parent . n_j < 0) gives
        sign[i] = sign[r] * (-1)^(parity[i] xor parity[r]).

    Notes
    -----
    Filter-Kruskal (`_forest_edges`). Below 2**30 nodes the union-find is 32-bit
    and each edge's ends and parity are packed beside its key through the radix
    sort, so Kruskal's loop reads the edges as a stream.
    """
    n = indptr.shape[0] - 1
    if n < _WIDE_NODES:
        link32 = (2 * np.arange(n)).astype(np.int32)
        kept_a, kept_b, n_kept = _forest_edges(
            indptr, cols, weights, opposed, link32, False, _LIGHT_SHARE, _FILTER_MIN, work
        )
        labels, n_comp, parity = _forest_labels(link32)
    else:
        link64 = 2 * np.arange(n)
        kept_a, kept_b, n_kept = _forest_edges(
            indptr, cols, weights, opposed, link64, True, _LIGHT_SHARE, _FILTER_MIN, work
        )
        labels, n_comp, parity = _forest_labels(link64)
    return kept_a[:n_kept], kept_b[:n_kept], labels, n_comp, parity
