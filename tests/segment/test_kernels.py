"""numba kernels against the plain references (and once with the JIT off)."""

from __future__ import annotations

import heapq

import numpy as np
import pytest

from pointatlas._core._sort import stable_argsort
from pointatlas.neighbors import query_knn
from pointatlas.segment import _kernels as K
from pointatlas.segment import vsa_segment
from pointatlas.segment._kernels import _heap
from pointatlas.segment._kernels._merge import _candidate_pairs_sorted, _sort_entries
from tests.jit_off import JIT_OFF, run_module_without_jit

from . import reference
from .examples import figure_4_1

if JIT_OFF:
    # without the JIT the merge's slot hash (a 64-bit multiply that wraps by
    # design) runs on numpy int64 scalars, which warn on overflow
    pytestmark = pytest.mark.filterwarnings(
        "ignore:overflow encountered in scalar multiply:RuntimeWarning"
    )


def _cloud(seed, n=80, k=6):
    rng = np.random.default_rng(seed)
    points = rng.random((n, 3))
    normals = rng.normal(size=(n, 3)) + [0, 0, 2.0]
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    table, _ = query_knn(points, k)
    return points, normals, table


@pytest.mark.parametrize("seed", range(4))
def test_symmetric_csr(seed):
    _, _, table = _cloud(seed)
    table = table.copy()
    table[3, 2] = -1  # ignored entry
    indptr, indices = K.symmetric_csr(table, table.shape[0])
    lists = reference.symmetric_lists(table, table.shape[0])
    for i, row in enumerate(lists):
        assert indices[indptr[i] : indptr[i + 1]].tolist() == row


@pytest.mark.parametrize("seed", range(4))
@pytest.mark.parametrize("tied", [False, True])
def test_flood_matches_reference(seed, tied):
    """Same labels as the heapq flood; with axis-aligned normals many keys tie and
    the order falls to (point, region)."""
    _, normals, table = _cloud(seed)
    if tied:
        normals = np.eye(3)[np.random.default_rng(seed).integers(0, 3, normals.shape[0])]
    n = normals.shape[0]
    indptr, indices = K.symmetric_csr(table, n)
    lists = reference.symmetric_lists(table, n)
    seeds = np.random.default_rng(seed).choice(n, size=5, replace=False)
    seed_normals = normals[seeds]
    ours = K.flood(indptr, indices, normals, seeds, seed_normals)
    ref = reference.flood_reference(lists, normals, seeds, seed_normals)
    np.testing.assert_array_equal(ours, ref)


def test_flood_edge_cases():
    # one point; an unreachable point keeps -1
    normals = np.array([[0.0, 0.0, 1.0]])
    indptr, indices = K.symmetric_csr(np.zeros((1, 1), dtype=np.int64), 1)
    assert K.flood(indptr, indices, normals, np.array([0]), normals).tolist() == [0]
    normals = np.tile([0.0, 0.0, 1.0], (3, 1))
    table = np.array([[0, 1], [1, 0], [2, -1]])
    indptr, indices = K.symmetric_csr(table, 3)
    assert K.flood(indptr, indices, normals, np.array([0]), normals[:1]).tolist() == [0, 0, -1]


@pytest.mark.parametrize("seed", range(4))
def test_switch_kernels_match_reference(seed):
    _, normals, table = _cloud(seed)
    n = normals.shape[0]
    indptr, indices = K.symmetric_csr(table, n)
    lists = reference.symmetric_lists(table, n)
    rng = np.random.default_rng(seed)
    labels = rng.integers(0, 4, size=n)
    prox = rng.normal(size=(4, 3))
    prox /= np.linalg.norm(prox, axis=1, keepdims=True)
    weights = rng.random(n)
    everyone = np.ones(n, dtype=np.int64)  # every point treated as a border point
    allpts = np.arange(n)
    moved, new = K.batch_switch(
        indptr, indices, normals, weights, labels, prox, everyone, 1e-12, allpts
    )
    ours = labels.copy()
    ours[moved] = new
    ref = reference.batch_switch_reference(lists, normals, weights, labels, prox, 1e-12)
    np.testing.assert_array_equal(ours, ref)
    assert moved.size == int((ours != labels).sum())
    # the border suffices
    foreign = K.foreign_counts(indptr, indices, labels)
    for i in range(n):
        assert foreign[i] == sum(labels[j] != labels[i] for j in lists[i])
    moved_b, new_b = K.batch_switch(
        indptr, indices, normals, weights, labels, prox, foreign, 1e-12, allpts
    )
    np.testing.assert_array_equal(moved_b, moved)
    np.testing.assert_array_equal(new_b, new)
    # incremental sums and foreign counts agree with recomputation
    wsum = np.bincount(labels, weights, minlength=4)
    ssum = np.stack(
        [np.bincount(labels, weights * normals[:, d], minlength=4) for d in range(3)], 1
    )
    counts = np.bincount(labels, minlength=4)
    lab2 = labels.copy()
    wn = weights[:, None] * normals
    K.apply_moves(indptr, indices, lab2, wsum, ssum, counts, foreign, weights, wn, moved, new)
    np.testing.assert_array_equal(lab2, ref)
    np.testing.assert_allclose(wsum, np.bincount(ref, weights, minlength=4), atol=1e-12)
    np.testing.assert_array_equal(counts, np.bincount(ref, minlength=4))
    np.testing.assert_array_equal(foreign, K.foreign_counts(indptr, indices, lab2))
    np.testing.assert_array_equal(K.boundary_points(indptr, indices, lab2), np.flatnonzero(foreign))
    foreign = K.foreign_counts(indptr, indices, labels)
    p, h, gain = K.best_single_move(indptr, indices, normals, weights, labels, prox, foreign)
    rp, rh, rgain = reference.best_single_move_reference(lists, normals, weights, labels, prox)
    assert (p, h) == (rp, rh) and gain == pytest.approx(rgain)


@pytest.mark.parametrize("seed", range(4))
@pytest.mark.parametrize("angle", [True, False])
def test_hold_under_threshold_matches_reference(seed, angle):
    """The local switch's filter (docs/decisions/segment.md "Local mode"): the kept
    moves are the reference's, some are dropped, and after them no region that was
    under the threshold is over it."""
    rng = np.random.default_rng(seed)
    n, m = 300, 8
    labels = rng.integers(0, m, size=n)
    axes = rng.normal(size=(m, 3))
    normals = axes[labels] + rng.normal(0, rng.uniform(0.1, 0.6, m)[labels, None], (n, 3))
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    w = rng.uniform(0.5, 1.5, n)
    wn = w[:, None] * normals
    wsum = np.bincount(labels, w, minlength=m)
    ssum = np.stack([np.bincount(labels, wn[:, d], minlength=m) for d in range(3)], 1)
    moved = np.flatnonzero(rng.random(n) < 0.3)
    new = (labels[moved] + rng.integers(1, m, moved.size)) % m
    mean_cos = np.linalg.norm(ssum, axis=1) / wsum
    l21 = 2.0 * (wsum - np.linalg.norm(ssum, axis=1))
    eta, min_cos = (None, float(np.median(mean_cos))) if angle else (float(np.median(l21)), None)
    keep = K.hold_under_threshold(
        moved,
        new,
        labels,
        wsum,
        ssum,
        w,
        wn,
        0.0 if eta is None else eta,
        0.0 if min_cos is None else min_cos,
        angle,
    )
    ref = reference.hold_under_threshold_reference(
        moved, new, labels, wsum, ssum, w, wn, eta, min_cos
    )
    np.testing.assert_array_equal(keep, ref)
    assert 0 < keep.sum() < keep.size
    over = (
        (lambda ww, ss: np.linalg.norm(ss, axis=1) < min_cos * ww)
        if angle
        else (lambda ww, ss: 2.0 * (ww - np.linalg.norm(ss, axis=1)) > eta)
    )
    before = over(wsum, ssum)
    lab, ws, ss = labels.copy(), wsum.copy(), ssum.copy()
    counts = np.bincount(labels, minlength=m)
    indptr, indices = np.zeros(n + 1, dtype=np.int64), np.zeros(0, dtype=np.int64)
    K.apply_moves(
        indptr,
        indices,
        lab,
        ws,
        ss,
        counts,
        np.zeros(n, dtype=np.int64),
        w,
        wn,
        moved[keep],
        new[keep],
    )
    assert not np.any(over(ws, ss) & ~before & (ws > 0))


@pytest.mark.parametrize("seed", range(4))
def test_greedy_merge_matches_reference(seed):
    _, normals, table = _cloud(seed, n=60)
    n = normals.shape[0]
    indptr, indices = K.symmetric_csr(table, n)
    labels = np.arange(n)
    pairs = K.region_pairs(indptr, indices, labels, labels)
    np.testing.assert_array_equal(pairs, K.edge_pairs(indptr, indices))
    wsum = np.ones(n)
    ssum = normals.copy()
    for eta in (0.05, 0.5, 3.0):
        roots, n_merges = K.greedy_merge(pairs, wsum, ssum, eta, 0.0, False)
        ref = reference.greedy_merge_reference(pairs, wsum, ssum, eta)
        np.testing.assert_array_equal(K.canonical_labels(roots)[0], K.canonical_labels(ref)[0])
        assert n_merges == n - np.unique(roots).size


@pytest.mark.parametrize("seed", range(3))
def test_greedy_merge_ties_follow_pair_order(seed):
    """Axis-aligned normals make many unions cost exactly the same: the merges
    still follow (cost, a, b) order exactly, so the roots equal the reference's
    (the smaller id survives), not only the partition."""
    rng = np.random.default_rng(seed)
    n = 150
    table, _ = query_knn(rng.random((n, 3)), 6)
    normals = np.eye(3)[rng.choice(3, size=n, p=[0.15, 0.15, 0.7])]
    indptr, indices = K.symmetric_csr(table, n)
    pairs = K.edge_pairs(indptr, indices)
    for eta in (0.5, 2.5, 12.0):
        roots, _ = K.greedy_merge(pairs, np.ones(n), normals.copy(), eta, 0.0, False)
        ref = reference.greedy_merge_reference(pairs, np.ones(n), normals, eta)
        np.testing.assert_array_equal(roots, ref)


def _merge_input(rng, n, n_normals, singletons):
    """A random k-NN graph's region pairs and sums; few distinct normals (and
    integer weights) make many union costs tie exactly, many of them at 0."""
    table, _ = query_knn(rng.random((n, 3)), int(rng.integers(3, 9)))
    indptr, indices = K.symmetric_csr(table, n)
    basis = rng.normal(size=(n_normals, 3))
    basis /= np.linalg.norm(basis, axis=1, keepdims=True)
    normals = basis[rng.integers(0, n_normals, size=n)]
    weights = rng.integers(1, 4, size=n).astype(float)
    if singletons:
        return K.edge_pairs(indptr, indices), weights, weights[:, None] * normals
    # a later round: regions of several points, pairs listed once per boundary edge
    labels = K.canonical_labels(rng.integers(0, n // 3, size=n))[0]
    labels, m = K.connected_label_components(indptr, indices, labels)
    wsum = np.bincount(labels, weights, minlength=m)
    ssum = np.stack([np.bincount(labels, weights * normals[:, d], m) for d in range(3)], 1)
    rows = np.repeat(np.arange(n), np.diff(indptr))
    a, b = labels[rows], labels[indices]
    keep = a < b
    pairs = np.stack([a[keep], b[keep]], 1)
    if rng.random() < 0.5:  # unsorted, repeated pairs
        pairs = pairs[rng.permutation(pairs.shape[0])]
    else:
        pairs = np.unique(pairs, axis=0)
    return pairs, wsum, ssum


@pytest.mark.parametrize("seed", range(12))
def test_greedy_merge_matches_lazy_reference(seed):
    """The kernel (sorted stream + heap, dedupe table, prefetching) takes exactly
    the decisions of the plain lazy loop: same roots and merge count, in eta and
    angle mode, from singletons and from multi-point regions, with tied costs."""
    rng = np.random.default_rng(100 + seed)
    n = int(rng.integers(20, 400))
    pairs, wsum, ssum = _merge_input(rng, n, int(rng.integers(1, 6)), seed % 2 == 0)
    for eta in (0.0, 0.3, 2.0, 40.0):
        got = K.greedy_merge(pairs, wsum, ssum, eta, 0.0, False)
        ref = reference.greedy_merge_lazy_reference(pairs, wsum, ssum, eta)
        np.testing.assert_array_equal(got[0], ref[0])
        assert got[1] == ref[1]
    min_cos = float(np.cos(rng.uniform(0.05, 0.8)))
    got = K.greedy_merge(pairs, wsum, ssum, 0.0, min_cos, True)
    ref = reference.greedy_merge_lazy_reference(pairs, wsum, ssum, 0.0, min_cos, True)
    np.testing.assert_array_equal(got[0], ref[0])
    assert got[1] == ref[1]


def test_sort_entries_is_stable_argsort():
    rng = np.random.default_rng(1)
    for keys in (
        np.abs(np.round(rng.normal(size=5000), 2)),  # many ties
        np.repeat(np.abs(_random_doubles(rng, 3000)), 2)[rng.permutation(6000)],
        np.zeros(10),
        np.empty(0),
    ):
        codes = rng.integers(0, 2**40, size=keys.shape[0])
        order = stable_argsort(keys)
        ks, ps = _sort_entries(keys, codes)
        np.testing.assert_array_equal(ks, keys[order].view(np.int64))
        np.testing.assert_array_equal(ps, codes[order])


@pytest.mark.parametrize("seed", range(4))
def test_merge_candidate_pairs_table_and_sort_agree(seed):
    """The byte-table path and the sorting path give the same pairs as a plain scan."""
    rng = np.random.default_rng(seed)
    n = 300
    table, _ = query_knn(rng.random((n, 3)), 6)
    indptr, indices = K.symmetric_csr(table, n)
    labels = K.canonical_labels(rng.integers(0, 40, size=n))[0]
    m = int(labels.max()) + 1
    foreign = K.foreign_counts(indptr, indices, labels)
    dirty = rng.random(m) < 0.5
    cost = rng.random(m) * 10.0
    points = np.flatnonzero(rng.random(n) < 0.7)
    limit = 8.0
    slack = limit + 1e-9 * (1.0 + limit)
    expected = set()
    for i in points:
        li = labels[i]
        if foreign[i] == 0 or cost[li] >= 0.5 * slack:
            continue
        for j in indices[indptr[i] : indptr[i + 1]]:
            lj = labels[j]
            if lj != li and (dirty[li] or dirty[lj]) and cost[li] + cost[lj] < slack:
                expected.add((min(li, lj), max(li, lj)))
    expected = np.array(sorted(expected), dtype=np.int64).reshape(-1, 2)
    args = (indptr, indices, labels, foreign, dirty, cost)
    np.testing.assert_array_equal(K.merge_candidate_pairs(*args, limit, points), expected)
    np.testing.assert_array_equal(_candidate_pairs_sorted(*args, slack, points), expected)


def test_merge_angle_mode_respects_bound():
    _, normals, table = _cloud(7, n=60)
    n = normals.shape[0]
    indptr, indices = K.symmetric_csr(table, n)
    pairs = K.edge_pairs(indptr, indices)
    min_cos = np.cos(0.3)
    roots, _ = K.greedy_merge(pairs, np.ones(n), normals.copy(), 0.0, min_cos, True)
    for r in np.unique(roots):
        s = normals[roots == r].sum(axis=0)
        assert np.linalg.norm(s) >= min_cos * (roots == r).sum() - 1e-12


def test_components_and_pairs():
    table = np.array([[0, 1], [1, 2], [2, 1], [3, 4], [4, 3]])
    indptr, indices = K.symmetric_csr(table, 5)
    labels = np.array([7, 7, 7, 7, 2])
    pieces, m = K.connected_label_components(indptr, indices, labels)
    assert pieces.tolist() == [0, 0, 0, 1, 2] and m == 3
    assert K.region_pairs(indptr, indices, pieces, np.arange(5)).tolist() == [[1, 2]]
    assert K.canonical_labels(np.array([5, 2, 5, 0]))[0].tolist() == [0, 1, 0, 2]


@pytest.mark.parametrize("seed", range(2))
def test_farthest_neighbor_distances_match_reference(seed):
    rng = np.random.default_rng(seed)
    points = rng.random((60, 3))
    points[5] = points[4]  # a duplicate
    table = query_knn(points, 5)[0]
    table[7] = 7  # no neighbour of its own (others may still list it)
    indptr, indices = K.symmetric_csr(table, 60)
    lists = reference.symmetric_lists(table, 60)
    got = K.farthest_neighbor_distances(indptr, indices, points)
    np.testing.assert_allclose(
        got, reference.farthest_neighbor_reference(lists, points), rtol=1e-14, atol=0
    )
    lone = K.symmetric_csr(np.array([[0], [1]]), 2)
    assert K.farthest_neighbor_distances(*lone, points[:2]).tolist() == [0.0, 0.0]


@pytest.mark.parametrize("seed", range(3))
def test_region_growing_kernel_matches_reference(seed):
    points, normals, table = _cloud(seed, k=8)
    curv = reference.curvature_reference(points, table)
    order = np.lexsort((np.arange(points.shape[0]), curv))
    thr = float(np.median(curv))
    cos_t = np.cos(0.6)
    ours = K.region_growing(table, normals, curv, order, cos_t, thr)
    ref = reference.region_growing_reference(table, normals, curv, cos_t, thr)
    np.testing.assert_array_equal(ours, ref)


@pytest.mark.parametrize("seed", range(4))
def test_touched_points_switch_is_exact(seed):
    """After moves, re-examining only points next to changed regions finds the
    same moves as scanning every point."""
    _, normals, table = _cloud(seed)
    n = normals.shape[0]
    indptr, indices = K.symmetric_csr(table, n)
    rng = np.random.default_rng(seed)
    m = 12
    labels = rng.integers(0, m, size=n)
    weights = np.ones(n)
    wn = normals.copy()
    wsum = np.bincount(labels, weights, minlength=m)
    ssum = np.stack([np.bincount(labels, normals[:, d], minlength=m) for d in range(3)], 1)
    counts = np.bincount(labels, minlength=m)
    foreign = K.foreign_counts(indptr, indices, labels)
    allpts = np.arange(n)
    dirty = np.ones(m, dtype=bool)
    for _ in range(6):
        prox = ssum / np.maximum(np.linalg.norm(ssum, axis=1, keepdims=True), 1e-300)
        cand = K.touched_points(indptr, indices, labels, foreign, dirty)
        full = K.batch_switch(indptr, indices, normals, weights, labels, prox, foreign, 0.0, allpts)
        part = K.batch_switch(indptr, indices, normals, weights, labels, prox, foreign, 0.0, cand)
        np.testing.assert_array_equal(full[0], part[0])
        np.testing.assert_array_equal(full[1], part[1])
        dirty[:] = False
        dirty[labels[full[0]]] = True
        dirty[full[1]] = True
        K.apply_moves(indptr, indices, labels, wsum, ssum, counts, foreign, weights, wn, *full)


def _bounded_switch_run(seed, n=300, m=6, iters=8):
    """Drive `batch_switch_bounded` as `vsa_segment` does (memo, drift, a merge
    renumbering half-way) and check every step against the full `batch_switch`."""
    points, normals, table = _cloud(seed, n=n, k=8)
    indptr, indices = K.symmetric_csr(table, n)
    # a sensible start: regions by x-slab, proxies close to each other
    labels = np.minimum((points[:, 0] * m).astype(np.int64), m - 1)
    weights = np.random.default_rng(seed).uniform(0.0, 2.0, n)
    weights[:5] = 0.0
    wn = weights[:, None] * normals
    wsum = np.bincount(labels, weights, minlength=m)
    ssum = np.stack([np.bincount(labels, wn[:, d], minlength=m) for d in range(3)], 1)
    counts = np.bincount(labels, minlength=m)
    foreign = K.foreign_counts(indptr, indices, labels)
    allpts = np.arange(n)
    memo = np.full((n, 6), np.nan)
    drift = np.zeros(m)
    prev = None
    skipped = 0
    for it in range(iters):
        if it == iters // 2:  # merge regions 0 and 1 (ids renumbered)
            roots = np.arange(wsum.shape[0])
            roots[1] = 0
            remap, m2 = K.canonical_labels(roots)
            labels = remap[labels]
            wsum = np.bincount(remap, wsum, minlength=m2)
            ssum = np.stack([np.bincount(remap, ssum[:, d], minlength=m2) for d in range(3)], 1)
            counts = np.bincount(remap, counts, minlength=m2).astype(np.int64)
            foreign = K.foreign_counts(indptr, indices, labels)
            joined = np.bincount(remap, minlength=m2) > 1
            memo[K.touched_points(indptr, indices, labels, foreign, joined), 0] = np.nan
            K.renumber_memo(memo, remap)
            drift = np.bincount(remap, drift, minlength=m2)
            moved_prox = np.zeros((m2, 3))
            moved_prox[remap[: prev.shape[0]]] = prev
            prev = moved_prox
        prox = ssum / np.maximum(np.linalg.norm(ssum, axis=1, keepdims=True), 1e-300)
        if prev is not None:
            drift += np.linalg.norm(prox - prev, axis=1)
        prev = prox
        full = K.batch_switch(
            indptr, indices, normals, weights, labels, prox, foreign, 1e-12, allpts
        )
        known = ~np.isnan(memo[:, 0]) & (foreign > 0) & (weights > 0)
        ids = np.where(known[:, None], memo[:, 2:5], -1).astype(np.int64)
        total = drift[labels] + np.where(ids >= 0, drift[np.maximum(ids, 0)], 0).sum(1)
        before = memo[:, 1].copy()
        got = K.batch_switch_bounded(
            indptr, indices, normals, weights, labels, prox, foreign, 1e-12, drift, memo
        )
        np.testing.assert_array_equal(full[0], got[0])
        np.testing.assert_array_equal(full[1], got[1])
        # a point whose regions drifted but whose snapshot was kept was skipped
        skipped += int((known & (total > before) & (memo[:, 1] == before)).sum())
        K.forget_around(indptr, indices, got[0], memo)
        K.apply_moves(indptr, indices, labels, wsum, ssum, counts, foreign, weights, wn, *got)
    return skipped


@pytest.mark.parametrize("seed", range(4))
def test_bounded_switch_is_exact(seed):
    """Skipping points by the proxy-drift bound finds exactly the moves of a full
    scan, across proxy updates and a merge renumbering, and does skip points."""
    assert _bounded_switch_run(seed) > 0


def test_stable_argsort_matches_numpy():
    rng = np.random.default_rng(0)
    for values in (
        rng.random(5000) * 4,
        np.round(rng.normal(size=3000), 2),  # many ties, negatives
        np.array([0.0, -0.0, 1.0, -0.0, 0.0, -1.5, 2.0**-1074, np.inf, -np.inf]),
        np.empty(0),
        # every 8-bit digit varies: random bit patterns (finite), with repeats
        np.repeat(_random_doubles(rng, 20_000), 2)[rng.permutation(40_000)],
        1.0 + rng.integers(0, 300, size=20_000) * 2.0**-52,  # only the low digits vary
    ):
        np.testing.assert_array_equal(stable_argsort(values), np.argsort(values, kind="stable"))


def _random_doubles(rng, n):
    bits = rng.integers(0, 2**63 - 1, size=n, dtype=np.int64, endpoint=True).view(np.float64)
    bits = np.where(np.isfinite(bits), bits, 1.0)
    return bits * np.where(rng.random(n) < 0.5, -1.0, 1.0)


@pytest.mark.parametrize("seed", range(3))
def test_heap_pops_in_key_code_order(seed):
    """The room's heap pops (key, code) in sorted order, ties by code, across
    growth and interleaved pushes and pops, like heapq."""
    rng = np.random.default_rng(seed)
    heap, base = _heap.heap_new(4)
    bits, bits_i = _heap.key_buffer()
    size = 0
    ref = []
    popped, expected = [], []
    for _ in range(600):
        if size and rng.random() < 0.4:
            popped.append((int(heap[base, 0]), int(heap[base, 1])))
            _heap.heap_pop(heap, base, size)
            size -= 1
            expected.append(heapq.heappop(ref))
        else:
            bits[0] = float(rng.integers(0, 5)) * 0.5  # many equal keys
            entry = (int(bits_i[0]), int(rng.integers(0, 50)))
            heap, base = _heap.heap_push(heap, base, size, *entry)
            size += 1
            heapq.heappush(ref, entry)
    while size:
        popped.append((int(heap[base, 0]), int(heap[base, 1])))
        _heap.heap_pop(heap, base, size)
        size -= 1
        expected.append(heapq.heappop(ref))
    assert popped == expected
    # keys are the bits of non-negative doubles: they pop in the order of the values
    values = np.concatenate([[0.0, 5e-324, 1e300], rng.random(300) * 10.0 ** rng.integers(-9, 9)])
    for v in values:
        bits[0] = v
        heap, base = _heap.heap_push(heap, base, size, bits_i[0], 0)
        size += 1
    out = []
    while size:
        out.append(np.array([heap[base, 0]]).view(np.float64)[0])
        _heap.heap_pop(heap, base, size)
        size -= 1
    assert out == sorted(values.tolist())


def test_bounded_switch_small_run():
    """The bounded switch on a small input (also part of the JIT-off run)."""
    assert _bounded_switch_run(0, n=60, iters=4) >= 0


def test_classic_vsa_figure_4_1_converges():
    points, normals, adjacency, seeds = figure_4_1(20)
    res = vsa_segment(points, normals, seeds=seeds, classic=True, neighbors=adjacency)
    assert res.converged and res.region_counts.tolist() == [41, 1]


#: The small kernel-vs-reference tests that run again with the JIT off (CONTRIBUTING.md, Tests):
#: one case of every kernel (a pytest ``-k`` expression).
NO_JIT_SELECTION = " or ".join(
    [
        "test_symmetric_csr[0]",
        "test_farthest_neighbor_distances_match_reference[0]",
        "test_flood_matches_reference[False-0]",
        "test_flood_matches_reference[True-0]",
        "test_flood_edge_cases",
        "test_switch_kernels_match_reference[0]",
        "test_hold_under_threshold_matches_reference[True-0]",
        "test_greedy_merge_matches_reference[0]",
        "test_greedy_merge_matches_lazy_reference[0]",
        "test_sort_entries_is_stable_argsort",
        "test_merge_candidate_pairs_table_and_sort_agree[0]",
        "test_merge_angle_mode_respects_bound",
        "test_components_and_pairs",
        "test_region_growing_kernel_matches_reference[0]",
        "test_bounded_switch_small_run",
        "test_stable_argsort_matches_numpy",
        "test_heap_pops_in_key_code_order[0]",
        "test_classic_vsa_figure_4_1_converges",
    ]
)


@pytest.mark.skipif(JIT_OFF, reason="already running with the JIT off")
def test_kernels_without_jit():
    out = run_module_without_jit(__file__, select=NO_JIT_SELECTION)
    assert "18 passed" in out, out[-500:]
