"""Regions below a minimum size join their best neighbour (beyond the thesis;
docs/decisions/segment.md "Small regions"). Private; inputs validated.

On noisy clouds VSA leaves many regions of a few points: a point whose normal the
noise tilted beyond the threshold of every neighbouring region stays a region of
its own, and nothing in 4.3.3 joins it later (the merge test rejects the union as
the split test would). Here every region with fewer than ``min_size`` points joins
the neighbouring region whose proxy fits it best: the one whose union with it
adds the least L21 energy (Eq. 4.4), as VSA's merge orders its candidates.
"""

from __future__ import annotations

import numpy as np

from ._kernels import boundary_points, canonical_labels, region_pairs
from ._sums import energy_opt, region_sums, row_norms

__all__ = ["added_l21", "merge_small_regions", "small_region_groups"]


def added_l21(s_a, s_b):
    """The L21 energy a union adds to its two parts, per row of (m, 3) sums S.

    At the optimal normals L21 = 2 (W - |S|), so the union adds
    2 (|S_a| + |S_b| - |S_a + S_b|), computed here without the cancellation as
    4 (|S_a| |S_b| - S_a . S_b) / (|S_a| + |S_b| + |S_a + S_b|) (0 when both are 0).
    Symmetric bit for bit in a and b.
    """
    la, lb = row_norms(s_a), row_norms(s_b)
    lu = row_norms(s_a + s_b)
    dot = s_a[:, 0] * s_b[:, 0] + s_a[:, 1] * s_b[:, 1] + s_a[:, 2] * s_b[:, 2]
    num = np.maximum(la * lb - dot, 0.0)
    den = la + lb + lu
    out = np.zeros_like(den)
    np.divide(4.0 * num, den, out=out, where=den > 0.0)
    return out


def _best_targets(pairs, ssum, small):
    """For every small region with a neighbour, the neighbour of least added L21
    (ties: the smaller id); returns (sources increasing, targets)."""
    a = np.concatenate([pairs[:, 0], pairs[:, 1]])
    b = np.concatenate([pairs[:, 1], pairs[:, 0]])
    sel = small[a]
    a, b = a[sel], b[sel]
    cost = added_l21(ssum[a], ssum[b])
    order = np.lexsort((b, cost, a))
    a, b = a[order], b[order]
    first = np.ones(a.shape[0], dtype=bool)
    first[1:] = a[1:] != a[:-1]
    return a[first], b[first]


def _roots(n, src, dst):
    """Follow every region's choice to the end of its chain; two regions that chose
    each other end at the smaller id. The choices form no longer cycle: along one
    the added energies would all be equal and each tie would pick a smaller id."""
    target = np.arange(n, dtype=np.int64)
    target[src] = dst
    mutual = (target[dst] == src) & (src < dst)
    target[src[mutual]] = src[mutual]
    for _ in range(n):
        nxt = target[target]
        if np.array_equal(nxt, target):
            break
        target = nxt
    return target


def small_region_groups(pairs, wsum, ssum, counts, min_size):
    """Join every region with fewer than ``min_size`` points to its best neighbour.

    Parameters are per region (ids 0..m-1): W, S, point counts, and ``pairs``
    (E, 2) the neighbouring regions. In rounds, every small region that has a
    neighbour picks the one whose union adds the least L21 (`added_l21`, ties:
    the smaller id); all picks of a round join at once (chains end at a region
    that picked none; two regions that picked each other join), the sums are
    recomputed and the next round starts, until no small region has a neighbour.
    Every round joins at least one pair, so at most m - 1 rounds run.

    Returns the new id of every region (0..m'-1, numbered by the smallest old id
    of each group) and m'.
    """
    m = wsum.shape[0]
    group = np.arange(m, dtype=np.int64)
    n_cur = m
    pairs = np.asarray(pairs, dtype=np.int64).reshape(-1, 2)
    wsum, ssum, counts = wsum.copy(), ssum.copy(), counts.copy()
    while pairs.shape[0]:
        small = counts < min_size
        if not small[pairs].any():
            break
        src, dst = _best_targets(pairs, ssum, small)
        remap, n_new = canonical_labels(_roots(n_cur, src, dst))
        group = remap[group]
        wsum = np.bincount(remap, weights=wsum, minlength=n_new)
        ssum = np.stack(
            [np.bincount(remap, weights=ssum[:, d], minlength=n_new) for d in range(3)], 1
        )
        counts = np.bincount(remap, weights=counts, minlength=n_new).astype(np.int64)
        pairs = remap[pairs]
        pairs = pairs[pairs[:, 0] != pairs[:, 1]]
        pairs = np.sort(pairs, axis=1)
        pairs = np.unique(pairs[:, 0] * n_new + pairs[:, 1])
        pairs = np.column_stack([pairs // n_new, pairs % n_new])
        n_cur = n_new
    return group, n_cur


def merge_small_regions(run, min_size):
    """The step "small_regions" of a `vsa_segment` run (`_vsa_run._VSARun`): its
    regions with fewer than ``min_size`` points join their best neighbour
    (`small_region_groups` on the region adjacency of Remark 6); labels, sums and
    the energy history are updated. Returns the number of regions that joined."""
    counts = run.counts
    if min_size <= 1 or not (counts[counts > 0] < min_size).any():
        return 0
    subset = boundary_points(run.indptr, run.indices, run.labels)
    pairs = region_pairs(run.indptr, run.indices, run.labels, subset)
    group, m = small_region_groups(pairs, run.wsum, run.ssum, counts, min_size)
    if m == run.m:
        return 0
    n_joined = run.m - m
    run.labels, run.m = canonical_labels(group[run.labels])
    run.wsum, run.ssum, run.counts = region_sums(run.labels, run.m, run.w, run.wn)
    run.record("small_regions", energy_opt(run.wsum, run.ssum))
    return n_joined
