"""Regions below a minimum size join their best neighbour (beyond the thesis;
docs/decisions/segment.md "Small regions"). Private; inputs validated.

On noisy clouds VSA leaves many regions of a few points: a point whose normal the
noise tilted beyond the threshold of every neighbouring region stays a region of
its own, and nothing in 4.3.3 joins it later (the merge test rejects the union as
the split test would). Here every region with fewer than ``min_size`` points joins
the neighbouring region whose proxy fits it best, among those on whose surface it
lies: the one whose union with it adds the least L21 energy (Eq. 4.4), as VSA's
merge orders its candidates.
"""

from __future__ import annotations

import numpy as np
from scipy import sparse
from scipy.sparse import csgraph

from .._core import PointAtlasError
from ._kernels import canonical_labels
from ._sums import energy_opt, proxy_normals, region_sums, row_norms
from ._vsa_run import _group_median, _normal_gap, neighbourhood_reach

__all__ = [
    "added_l21",
    "join_picks",
    "merge_small_regions",
    "pick_merge_targets",
    "small_region_groups",
]


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


def pick_merge_targets(a, b, ssum):
    """The neighbour each small region joins: the one whose union adds the least L21.

    The rule of `VSAOptions.min_region_size` (docs/decisions/segment.md "Small
    regions"), shared with the stitching of tiled segmentations
    (`pointatlas.batch.tiled_segment`). The added energy is that of Eq. 4.4 at the
    optimal normals, computed from the region sums alone.

    Parameters
    ----------
    a, b : (M,) int64 arrays
        Directed candidate pairs ``a[i] -> b[i]``: region ``a[i]`` may join ``b[i]``.
    ssum : (R, 3) float64 array
        Per region, the area-weighted sum of its point normals (the S of Eq. 4.4).

    Returns
    -------
    sources : (P,) int64 array
        The distinct regions of ``a``, increasing.
    targets : (P,) int64 array
        For each source, the ``b`` of least added L21 (ties: the smaller id).

    Raises
    ------
    PointAtlasError
        When ``a`` and ``b`` are not two integer arrays of one length or ``ssum`` is
        not (R, 3) (ids out of range: numpy's ``IndexError``).
    """
    a, b, ssum = np.asarray(a), np.asarray(b), np.asarray(ssum)
    if a.ndim != 1 or a.shape != b.shape or a.dtype.kind not in "iu" or b.dtype.kind not in "iu":
        raise PointAtlasError("pick_merge_targets: a and b must be integer arrays of one length")
    if ssum.ndim != 2 or ssum.shape[1] != 3:
        raise PointAtlasError(f"pick_merge_targets: ssum must be (R, 3), got {ssum.shape}")
    cost = added_l21(ssum[a], ssum[b])
    order = np.lexsort((b, cost, a))
    a, b = a[order], b[order]
    first = np.ones(a.shape[0], dtype=bool)
    first[1:] = a[1:] != a[:-1]
    return a[first], b[first]


def join_picks(n, src, dst):
    """The regions 0..n-1 after every ``src`` joined its pick ``dst``: the new id of
    every region (numbered by the smallest old id of each group) and their number.

    The groups are the connected pieces of the picks (chains, two regions that
    picked each other, and cycles, which the surface test of `_candidates` allows:
    it is not symmetric)."""
    graph = sparse.coo_array((np.ones(src.shape[0]), (src, dst)), shape=(n, n))
    _, comp = csgraph.connected_components(graph, directed=True, connection="weak")
    return canonical_labels(comp.astype(np.int64))


def small_region_groups(pairs, wsum, ssum, counts, min_size):
    """Join every region with fewer than ``min_size`` points to its best neighbour,
    by region sums alone (the plane test of `merge_small_regions` needs points).

    Parameters are per region (ids 0..m-1): W, S, point counts, and ``pairs``
    (E, 2) the neighbouring regions. In rounds, every small region that has a
    neighbour picks the one whose union adds the least L21 (`pick_merge_targets`); the
    picks of a round join at once (`join_picks`), the sums are recomputed and the
    next round starts, until no small region has a neighbour. Every round joins
    at least one pair, so at most m - 1 rounds run.

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
        a = np.concatenate([pairs[:, 0], pairs[:, 1]])
        b = np.concatenate([pairs[:, 1], pairs[:, 0]])
        if not small[a].any():
            break
        src, dst = pick_merge_targets(a[small[a]], b[small[a]], ssum)
        remap, n_new = join_picks(n_cur, src, dst)
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


def _candidates(run, small, rows, cols, reach):
    """Directed pairs (small region a, neighbouring region b) where a lies on b's
    surface: the median, over the graph edges (``rows``, ``cols``) from a point
    of a to a point of b, of their distance along b's proxy normal is at most
    ``reach``."""
    labels = run.labels
    a, b = labels[rows], labels[cols]
    e = small[a] & (a != b)
    if not e.any():
        return a[:0], b[:0]
    prox = proxy_normals(labels, run.wsum, run.ssum, run.counts, run.normals)
    a, b = a[e], b[e]
    gap = _normal_gap(run.points, rows[e], cols[e], prox[b])
    m = run.m
    key, inv = np.unique(a * m + b, return_inverse=True)
    offset = _group_median(inv.reshape(-1), gap, key.shape[0])
    key = key[offset <= reach]
    return key // m, key % m


def _edges_of(indptr, indices, points):
    """The graph edges (row, column) of the given points, in their order."""
    lens = indptr[points + 1] - indptr[points]
    rows = np.repeat(points, lens)
    first = np.repeat(np.cumsum(lens) - lens, lens)
    pos = np.arange(rows.shape[0]) - first + np.repeat(indptr[points], lens)
    return rows, indices[pos]


def merge_small_regions(run, min_size):
    """The step "small_regions" of a `vsa_segment` run (`_vsa_run._VSARun`): its
    regions with fewer than ``min_size`` points join their best neighbour.

    In rounds: every small region picks, among the neighbouring regions on whose
    surface it lies (`_candidates`, within the neighbourhood reach), the one whose
    union with it adds the least L21 (`pick_merge_targets`); the picks join at once
    (`join_picks`), labels and sums are updated, until no small region has such a
    neighbour. A small region off every neighbouring surface (or with no
    neighbour) stays. A region at the minimum never becomes small again, so only
    the edges of the points in the regions small at the start are read after the
    reach. Returns the number of regions that joined.
    """
    small = run.counts < min_size
    if min_size <= 1 or not run.indices.size or not small.any():
        return 0
    reach = neighbourhood_reach(run.indptr, run.indices, run.points)
    rows, cols = _edges_of(run.indptr, run.indices, np.flatnonzero(small[run.labels]))
    m_start = run.m
    while True:
        src, dst = _candidates(run, run.counts < min_size, rows, cols, reach)
        if not src.size:
            break
        src, dst = pick_merge_targets(src, dst, run.ssum)
        remap, m = join_picks(run.m, src, dst)
        run.labels, run.m = remap[run.labels], m
        run.wsum = np.bincount(remap, weights=run.wsum, minlength=m)
        run.ssum = np.stack(
            [np.bincount(remap, weights=run.ssum[:, d], minlength=m) for d in range(3)], 1
        )
        run.counts = np.bincount(remap, weights=run.counts, minlength=m).astype(np.int64)
    if run.m == m_start:
        return 0
    run.labels, run.m = canonical_labels(run.labels)
    run.wsum, run.ssum, run.counts = region_sums(run.labels, run.m, run.w, run.wn)
    run.record("small_regions", energy_opt(run.wsum, run.ssum))
    return m_start - run.m
