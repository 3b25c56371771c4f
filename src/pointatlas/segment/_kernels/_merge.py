"""The merge step (thesis 4.3.3 b): candidate region pairs and greedy
cheapest-union-first merging on the region adjacency graph."""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from ..._core._prefetch import prefetch_row as _prefetch
from ..._core._sort import radix_sort_payload
from ._csr import pairs_of_keys
from ._heap import heap_new, heap_pop, heap_push, key_buffer, less_entry

#: `merge_candidate_pairs` marks pairs in a byte table (cheap regions x all
#: regions) when it has at most this many bytes per scanned point (plus 1 MiB);
#: otherwise it sorts the raw pair keys
_PAIR_TABLE_BYTES_PER_POINT = 8


@njit(cache=True, inline="always")
def _is_candidate(li, lj, dirty, cost, limit):
    """Regions li, lj (of a boundary edge) form a merge candidate: different, one of
    them changed since the last pass, and the sum of their costs below ``limit``."""
    return lj != li and (dirty[li] or dirty[lj]) and cost[li] + cost[lj] < limit


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
    are sorted instead (`_candidate_pairs_sorted`). Same result either way. The
    kernels (`_candidate_keys`) give the pair keys, `pairs_of_keys` the pairs.
    """
    limit = limit + 1e-9 * (1.0 + abs(limit))  # round-off slack: never drop a candidate
    key = _candidate_keys(indptr, indices, labels, foreign, dirty, cost, limit, points)
    return pairs_of_keys(key, cost.shape[0])


@njit(cache=True, parallel=True)
def _candidate_keys(indptr, indices, labels, foreign, dirty, cost, limit, points):
    """The keys a * m + b of `merge_candidate_pairs` (``limit`` with its slack; keys
    may repeat), by the byte table or, when that would be large, by
    `_candidate_keys_sorted`."""
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
        return np.empty(0, dtype=np.int64)
    if mc * m > _PAIR_TABLE_BYTES_PER_POINT * n + (1 << 20):
        return _candidate_keys_sorted(indptr, indices, labels, foreign, dirty, cost, limit, points)
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
    key = np.empty(start[mc], dtype=np.int64)
    for c in prange(mc):
        a = cheap[c]
        k = start[c]
        for b in range(m):
            if table[c * m + b]:
                key[k] = min(a, b) * m + max(a, b)
                k += 1
    return key


def _candidate_pairs_sorted(indptr, indices, labels, foreign, dirty, cost, limit, points):
    """`merge_candidate_pairs` by sorting every qualifying edge's pair key
    (``limit`` already has its round-off slack)."""
    key = _candidate_keys_sorted(indptr, indices, labels, foreign, dirty, cost, limit, points)
    return pairs_of_keys(key, cost.shape[0])


@njit(cache=True, parallel=True)
def _candidate_keys_sorted(indptr, indices, labels, foreign, dirty, cost, limit, points):
    """The pair key of every qualifying edge (`_candidate_pairs_sorted`)."""
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
    return key


#: how many stream entries ahead `greedy_merge` prefetches the union-find parents
#: (`_AHEAD_PARENT`) and the region sums (`_AHEAD_SUMS`) of a pair
_AHEAD_PARENT = 16
_AHEAD_SUMS = 8
#: low 32 bits of a pair code (a << 32) | b
_LOW = 0xFFFFFFFF
#: multiplier of the dedupe table's hash (a 64-bit LCG constant)
_HASH = 0x5851F42D4C957F2D


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


@njit(cache=True, inline="always")
def _acceptable(cost, w, s, eta, min_cos, use_angle):
    """A union is accepted when its L21 < eta, or, with ``use_angle``, when its
    mean normal cosine |S|/W >= ``min_cos``."""
    return (s >= min_cos * w) if use_angle else (cost < eta)


@njit(cache=True)
def _initial_entries(pairs, ws, eta, min_cos, use_angle):
    """The acceptable pairs as entries, in the order of ``pairs``: their union cost
    (+0.0 for -0.0: keys compare by their bits) and pair code (a << 32) | b, and
    whether the codes increase (`greedy_merge`'s initial entries; the region sums of
    the pairs a few rows ahead prefetched). Serial: a parallel loop cost numba about
    a CPU-second of compile for a pass that is a small part of the merge."""
    n = pairs.shape[0]
    keys = np.empty(n)
    codes = np.empty(n, dtype=np.int64)
    n_init = 0
    for e in range(n):
        if e + _AHEAD_PARENT < n:
            _prefetch(ws, pairs[e + _AHEAD_PARENT, 0])
            _prefetch(ws, pairs[e + _AHEAD_PARENT, 1])
        a = pairs[e, 0]
        b = pairs[e, 1]
        cost, w, s = _union_cost(ws, a, b)
        if _acceptable(cost, w, s, eta, min_cos, use_angle):
            keys[n_init] = cost + 0.0
            codes[n_init] = (min(a, b) << 32) | max(a, b)
            n_init += 1
    increasing = True
    for e in range(1, n_init):
        if codes[e] <= codes[e - 1]:
            increasing = False
            break
    return keys[:n_init], codes[:n_init], increasing


def _by_code(keys, codes):
    """Entries (``keys``, ``codes``) ordered stably by pair code (codes >= 0), with
    the radix sort of `_sort_entries`."""
    n = codes.shape[0]
    sorted_codes, by_pair = radix_sort_payload(
        codes.view(np.uint64).copy(),
        np.arange(n, dtype=np.int64),
        np.empty(n, dtype=np.uint64),
        np.empty(n, dtype=np.int64),
    )
    return keys[by_pair], sorted_codes.view(np.int64)


def _sort_entries(keys, codes):
    """Key bits and codes sorted stably by key: ``stable_argsort`` and two gathers
    in one LSD radix sort that carries the code (no random gather afterwards).

    ``keys`` are non-negative doubles without -0.0, whose int64 bits order as
    the values do; passes whose digit is the same for every key are skipped.
    Same output as ``keys[order].view(np.int64), codes[order]`` with ``order =
    stable_argsort(keys)``. The bit views are numpy's (`_sort_entries` and `_by_code`
    call the radix sort from Python): numba's ``view`` compiles for a tenth of a
    second per dtype pair.
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
def _find32(parent, i):
    while parent[i] != i:  # path halving
        parent[i] = parent[parent[i]]
        i = parent[i]
    return i


@njit(cache=True)
def _aligned_sums(wsum, ssum):
    """Rows (W, Sx, Sy, Sz) per region, 32 bytes each: numba allocates arrays on a
    32-byte boundary, so a row never straddles two cache lines."""
    m = wsum.shape[0]
    ws = np.empty((m, 4))
    for r in range(m):
        ws[r, 0] = wsum[r]
        ws[r, 1] = ssum[r, 0]
        ws[r, 2] = ssum[r, 1]
        ws[r, 3] = ssum[r, 2]
    return ws


@njit(cache=True, inline="always")
def _slot(code, mask):
    """Slot of a pair code in the dedupe table."""
    return ((code * _HASH) >> 20) & mask


@njit(cache=True, inline="always")
def _prefetch_stream(ps, head, ahead_parent, ahead_sums, parent, ws, version, slots, mask):
    """Prefetch for the stream entries popped soon: their parents
    ``_AHEAD_PARENT`` entries ahead; ``_AHEAD_SUMS`` ahead the sums, versions and
    dedupe slot of their probable roots (two steps up; a wrong guess only wastes
    the prefetch). Returns the updated counts of entries prefetched."""
    n_init = ps.shape[0]
    lim = min(head + _AHEAD_PARENT, n_init)
    while ahead_parent < lim:
        e = ps[ahead_parent]
        _prefetch(parent, e >> 32)
        _prefetch(parent, e & _LOW)
        ahead_parent += 1
    lim = min(head + _AHEAD_SUMS, n_init)
    while ahead_sums < lim:
        e = ps[ahead_sums]
        xa = parent[parent[e >> 32]]
        xb = parent[parent[e & _LOW]]
        _prefetch(ws, xa)
        _prefetch(ws, xb)
        xlo = np.int64(min(xa, xb))
        xhi = np.int64(max(xa, xb))
        _prefetch(version, xlo)
        _prefetch(version, xhi)
        _prefetch(slots, _slot((xlo << 32) | xhi, mask))
        ahead_sums += 1
    return ahead_parent, ahead_sums


@njit(cache=True, inline="always")
def _prefetch_pair(e, parent, ws, version, slots, mask):
    """Prefetch what popping the heap entry with code ``e`` will read (heap codes
    are roots when pushed)."""
    _prefetch(parent, e >> 32)
    _prefetch(parent, e & _LOW)
    _prefetch(ws, e >> 32)
    _prefetch(ws, e & _LOW)
    _prefetch(version, e >> 32)
    _prefetch(version, e & _LOW)
    _prefetch(slots, _slot(e, mask))


@njit(cache=True, inline="always")
def _queued_before(slots, mask, code, stamp):
    """True when an entry for ``code`` computed from the same region versions
    (``stamp``) was already pushed; otherwise remember this push and return False.

    The table is direct-mapped: a collision only costs an extra push, never a
    wrong drop (the code is compared too).
    """
    slot = _slot(code, mask)
    if slots[slot, 0] == code and slots[slot, 1] == stamp:
        return True
    slots[slot, 0] = code
    slots[slot, 1] = stamp
    return False


@njit(cache=True)
def _roots(parent):
    """Root of every region (int64)."""
    m = parent.shape[0]
    roots = np.empty(m, dtype=np.int64)
    for i in range(m):
        roots[i] = _find32(parent, i)
    return roots


def greedy_merge(pairs, wsum, ssum, eta, min_cos, use_angle):
    """Cheapest-union-first merging on the region adjacency graph (4.3.3 b).

    ``pairs`` (E, 2) are adjacent regions; ``wsum`` (m,) and ``ssum`` (m, 3) the
    per-region sums W = sum w_j and S = sum w_j n_j, so the L21 of a union is
    2 (W_a + W_b - |S_a + S_b|) in O(1). Key: that L21, ties by (a, b). A union
    is accepted when its L21 < eta, or, with ``use_angle``, when its mean normal
    cosine |S|/W >= ``min_cos``.

    Entries are evaluated lazily: L21 only grows with the point set, so a key
    pushed earlier is a lower bound of the pair's current cost; a popped pair
    whose current cost exceeds the next key is pushed back with the current
    cost, otherwise it is the cheapest and is merged, so in eta mode the order is
    exactly cheapest-first. The initial entries are sorted once by (key, pair)
    and read as a stream; pushed-back entries go to the heap (`heap_push`), and
    every pop takes the smaller of the stream's head and the heap's top. Returns
    the root of every region (union-find, the smaller id survives) and the
    number of merges.

    Internally a pair (a < b) is coded (a << 32) | b (same order as (a, b)) and
    a key by the int64 bits of the (non-negative) double, so an entry is two
    int64 compared lexicographically; fewer than 2**31 regions.

    The loop is bound by memory latency (from 1M singleton regions: millions of
    pops, each reading scattered parents, region sums, versions, dedupe slots
    and heap nodes that depend on one another), so the rows the next stream
    entries and the next heap top will read are prefetched, and the sift-down
    prefetches a level ahead. Prefetches are hints only: every decision, and so
    the result, is that of the plain loop. The loop is one function (about 60
    lines) because its state (stream head, heap, versions, dedupe table) is
    shared by every step.

    The stages (`_aligned_sums`, `_initial_entries`, `_by_code` when the pairs
    are not in code order, `_sort_entries`, `_merge_stream`) are called from
    Python one after the other: numba optimizes and emits the code of a kernel
    together with every kernel it calls, so one kernel calling the others would
    compile their code a second time (about a CPU-second on an empty cache). The
    two sorts are the shared radix sort called from Python with numpy's bit views
    (the grid k-NN compiles it for the same types), so they compile nothing.
    """
    m = wsum.shape[0]
    if m >= 2**31 - 1:
        raise ValueError("greedy_merge: at most 2**31 - 2 regions")
    ws = _aligned_sums(wsum, ssum)
    keys, codes, increasing = _initial_entries(pairs, ws, eta, min_cos, use_angle)
    if not increasing:
        keys, codes = _by_code(keys, codes)
    ks, ps = _sort_entries(keys, codes)  # stable: ties stay sorted by pair
    parent = np.arange(m, dtype=np.int32)  # union-find, updated by the loop
    buffer = key_buffer()
    return _merge_stream(ks, ps, ws, parent, pairs.shape[0], eta, min_cos, use_angle, buffer)


@njit(cache=True)
def _merge_stream(ks, ps, ws, parent, n_pairs, eta, min_cos, use_angle, buffer):
    """`greedy_merge`'s loop over the sorted initial entries (``ks`` key bits, ``ps``
    pair codes) and the heap of pushed-back ones; ``ws`` the region sums (`_aligned_sums`,
    updated in place), ``parent`` the union-find (int32 ``arange(m)``; numpy's, as
    numba's ``arange`` and ``astype`` compile apart), ``n_pairs`` the number of
    adjacent pairs (sizes the dedupe table), ``buffer`` a `key_buffer`. Returns the
    root of every region and the number of merges."""
    m = ws.shape[0]
    n_init = ks.shape[0]
    head = 0
    heap, base = heap_new(4096)
    size = 0
    n_merges = 0
    bits, bits_i = buffer
    # duplicates: many point edges map to the same region pair; remember the
    # region versions each pair was last pushed with and drop stale copies
    # (`_queued_before`; a slot's code and stamp share a row)
    version = np.zeros(m, dtype=np.int64)
    n_slots = 1024
    while n_slots < n_pairs:
        n_slots *= 2
    mask = n_slots - 1
    slots = np.empty((n_slots, 2), dtype=np.int64)
    for t in range(n_slots):  # a loop, not np.full: one spelling less to compile
        slots[t, 0] = -1
        slots[t, 1] = -1
    ahead_parent = 0  # stream entries whose parents were prefetched
    ahead_sums = 0  # stream entries whose (probable) roots' sums were prefetched
    while size > 0 or head < n_init:
        ahead_parent, ahead_sums = _prefetch_stream(
            ps, head, ahead_parent, ahead_sums, parent, ws, version, slots, mask
        )
        if size > 0 and (
            head == n_init or less_entry(heap[base, 0], heap[base, 1], ks[head], ps[head])
        ):
            key = heap[base, 0]
            pair = heap[base, 1]
            heap_pop(heap, base, size)
            size -= 1
            if size > 0:
                _prefetch_pair(heap[base, 1], parent, ws, version, slots, mask)
        else:
            key = ks[head]
            pair = ps[head]
            head += 1
        ra = _find32(parent, pair >> 32)
        rb = _find32(parent, pair & _LOW)
        if ra == rb:
            continue
        cost, w, s = _union_cost(ws, ra, rb)
        if not _acceptable(cost, w, s, eta, min_cos, use_angle):
            continue
        lo = np.int64(min(ra, rb))
        hi = np.int64(max(ra, rb))
        code = (lo << 32) | hi
        bits[0] = cost + 0.0
        ckey = bits_i[0]
        if ckey > key:
            still_min = True
            if size > 0 and not less_entry(ckey, code, heap[base, 0], heap[base, 1]):
                still_min = False
            if head < n_init and not less_entry(ckey, code, ks[head], ps[head]):
                still_min = False
            if not still_min:
                # stale lower bound: push back with the current cost, unless an
                # entry computed from the same regions is already queued
                stamp = (version[lo] << 32) | version[hi]
                if not _queued_before(slots, mask, code, stamp):
                    heap, base = heap_push(heap, base, size, ckey, code)
                    size += 1
                continue
        parent[hi] = lo
        version[lo] += 1
        ws[lo, 0] = w
        ws[lo, 1] += ws[hi, 1]
        ws[lo, 2] += ws[hi, 2]
        ws[lo, 3] += ws[hi, 3]
        n_merges += 1
    return _roots(parent), n_merges
