"""Slow, obvious references for the segment kernels (plain Python / numpy)."""

from __future__ import annotations

import heapq

import numpy as np
from scipy import sparse
from scipy.sparse import csgraph


def symmetric_lists(table: np.ndarray, n: int) -> list[list[int]]:
    """Sorted, symmetric, duplicate-free neighbour lists of a directed table."""
    sets = [set() for _ in range(n)]
    for i in range(table.shape[0]):
        for j in table[i]:
            j = int(j)
            if j >= 0 and j != i:
                sets[i].add(j)
                sets[j].add(i)
    return [sorted(s) for s in sets]


def flood_reference(lists, normals, seeds, seed_normals):
    """Thesis 4.2.2 flood with heapq; ties by (cost, point, region)."""
    n = len(lists)
    labels = np.full(n, -1, dtype=np.int64)
    heap = []
    for r, s in enumerate(seeds):
        labels[s] = r
    for r, s in enumerate(seeds):
        for j in lists[s]:
            if labels[j] < 0:
                heapq.heappush(heap, (float(np.sum((normals[j] - seed_normals[r]) ** 2)), j, r))
    while heap:
        _, p, r = heapq.heappop(heap)
        if labels[p] >= 0:
            continue
        labels[p] = r
        for j in lists[p]:
            if labels[j] < 0:
                heapq.heappush(heap, (float(np.sum((normals[j] - seed_normals[r]) ** 2)), j, r))
    return labels


def batch_switch_reference(lists, normals, weights, labels, prox, min_gain):
    out = labels.copy()
    for i in range(len(lists)):
        li = labels[i]
        cur = float(normals[i] @ prox[li])
        cands = sorted({int(labels[j]) for j in lists[i]} - {int(li)})
        best, best_label = cur, li
        for h in cands:
            d = float(normals[i] @ prox[h])
            if d > best:
                best, best_label = d, h
        if best_label != li and 2 * weights[i] * (best - cur) > min_gain:
            out[i] = best_label
    return out


def hold_under_threshold_reference(moved, new, labels, wsum, ssum, w, wn, eta, min_cos):
    """Moves kept by the local switch: drop every move into or out of a region that
    the kept moves push over the threshold (it was not over, is not left empty),
    until none is (numpy sums per round; ``eta`` None: angle mode)."""

    def over(ww, ss):
        length = np.linalg.norm(ss, axis=1)
        return length < min_cos * ww if eta is None else 2.0 * (ww - length) > eta

    m = wsum.shape[0]
    old = labels[moved]
    before = over(wsum, ssum)
    keep = np.ones(moved.shape[0], dtype=bool)
    while True:
        ww = wsum + np.bincount(new[keep], w[moved][keep], m)
        ww -= np.bincount(old[keep], w[moved][keep], m)
        ss = ssum.copy()
        for d in range(3):
            ss[:, d] += np.bincount(new[keep], wn[moved, d][keep], m)
            ss[:, d] -= np.bincount(old[keep], wn[moved, d][keep], m)
        bad = over(ww, ss) & ~before & (ww > 0)
        drop = keep & (bad[new] | bad[old])
        if not drop.any():
            return keep
        keep &= ~drop


def best_single_move_reference(lists, normals, weights, labels, prox):
    best = (0.0, -1, -1)
    for i in range(len(lists)):
        li = labels[i]
        for h in sorted({int(labels[j]) for j in lists[i]} - {int(li)}):
            gain = 2 * weights[i] * float(normals[i] @ prox[h] - normals[i] @ prox[li])
            if gain > best[0]:
                best = (gain, i, h)
    return best[1], best[2], best[0]


def greedy_merge_reference(pairs, wsum, ssum, eta):
    """Repeatedly merge the adjacent pair with the cheapest union L21 < eta."""
    m = len(wsum)
    wsum = list(map(float, wsum))
    ssum = [np.array(s, dtype=float) for s in ssum]
    root = list(range(m))
    adj = {tuple(sorted(map(int, p))) for p in pairs}

    def find(i):
        while root[i] != i:
            i = root[i]
        return i

    while True:
        cur = {tuple(sorted((find(a), find(b)))) for a, b in adj}
        cur = {p for p in cur if p[0] != p[1]}
        best = None
        for a, b in sorted(cur):
            cost = 2 * (wsum[a] + wsum[b] - np.linalg.norm(ssum[a] + ssum[b]))
            if cost < eta and (best is None or cost < best[0]):
                best = (cost, a, b)
        if best is None:
            break
        _, a, b = best
        root[b] = a
        wsum[a] += wsum[b]
        ssum[a] = ssum[a] + ssum[b]
    return np.array([find(i) for i in range(m)])


def greedy_merge_lazy_reference(pairs, wsum, ssum, eta, min_cos=0.0, use_angle=False):
    """Plain transcription of `greedy_merge`'s lazy loop (no stream/heap split, no
    dedupe table, no prefetching): pop the least (key bits, code) entry, merge it
    when its current cost is no larger than its key or still the least entry,
    otherwise push it back with the current cost. Returns (roots, n_merges)."""
    m = len(wsum)
    ws = np.column_stack([np.asarray(wsum, dtype=float), np.asarray(ssum, dtype=float)])
    parent = list(range(m))

    def find(i):
        while parent[i] != i:
            i = parent[i]
        return i

    def union_cost(a, b):
        s3 = ws[a, 1:] + ws[b, 1:]
        w = ws[a, 0] + ws[b, 0]
        s = float(np.sqrt(s3[0] * s3[0] + s3[1] * s3[1] + s3[2] * s3[2]))
        return max(2.0 * (w - s), 0.0) + 0.0, w, s

    def bits(x):
        return int(np.float64(x).view(np.int64))

    def ok(cost, w, s):
        return s >= min_cos * w if use_angle else cost < eta

    queue = []
    for a, b in pairs:
        a, b = int(a), int(b)
        cost, w, s = union_cost(a, b)
        if ok(cost, w, s):
            queue.append((bits(cost), (min(a, b) << 32) | max(a, b)))
    heapq.heapify(queue)
    n_merges = 0
    while queue:
        key, code = heapq.heappop(queue)
        ra, rb = find(code >> 32), find(code & 0xFFFFFFFF)
        if ra == rb:
            continue
        cost, w, s = union_cost(ra, rb)
        if not ok(cost, w, s):
            continue
        lo, hi = min(ra, rb), max(ra, rb)
        entry = (bits(cost), (lo << 32) | hi)
        if entry[0] > key and queue and not entry < queue[0]:
            heapq.heappush(queue, entry)
            continue
        parent[hi] = lo
        ws[lo, 0] = w
        ws[lo, 1:] += ws[hi, 1:]
        n_merges += 1
    return np.array([find(i) for i in range(m)]), n_merges


def region_growing_reference(table, normals, curvature, cos_threshold, curvature_threshold):
    n = len(normals)
    order = sorted(range(n), key=lambda i: (curvature[i], i))
    labels = np.full(n, -1, dtype=np.int64)
    region = 0
    for start in order:
        if labels[start] >= 0:
            continue
        labels[start] = region
        queue = [start]
        while queue:
            cur = queue.pop(0)
            for j in table[cur]:
                if j < 0 or labels[j] >= 0:
                    continue
                if abs(float(normals[cur] @ normals[j])) < cos_threshold:
                    continue
                labels[j] = region
                if curvature[j] <= curvature_threshold:
                    queue.append(int(j))
        region += 1
    return labels


def curvature_reference(points, table):
    out = np.empty(len(points))
    for i, row in enumerate(table):
        q = points[row] - points[row].mean(axis=0)
        ev = np.linalg.eigvalsh(q.T @ q)
        out[i] = ev[0] / ev.sum() if ev.sum() > 0 else 0.0
    return out


def n_pieces(lists, labels, region):
    """Connected pieces of one region in the graph."""
    members = np.flatnonzero(labels == region)
    pos = {int(p): t for t, p in enumerate(members)}
    rows, cols = [], []
    for p in members:
        for j in lists[p]:
            if j in pos:
                rows.append(pos[int(p)])
                cols.append(pos[j])
    g = sparse.csr_array((np.ones(len(rows)), (rows, cols)), shape=(members.size, members.size))
    return csgraph.connected_components(g, directed=False)[0]


def eta_reference(mean_curvature, n_points, split=0.5):
    """Eq. 4.9 by summing |n(u, v) - (0, 0, 1)|^2 over the paraboloid grid directly."""
    nu = int(np.ceil(np.sqrt(n_points - 1) / 2))
    if nu == 0:
        return 0.0
    inv_a2, inv_b2 = split * mean_curvature, (1 - split) * mean_curvature
    total = 0.0
    for j in range(-nu, nu + 1):
        for m in range(-nu, nu + 1):
            u, v = j / nu, m / nu
            nrm = np.array([-2 * u * inv_a2, -2 * v * inv_b2, 1.0])
            nrm /= np.linalg.norm(nrm)
            total += np.sum((nrm - [0, 0, 1]) ** 2)
    return total


def merge_small_reference(points, lists, normals, weights, labels, min_size):
    """`merge_small_regions` written out: regions are sets of points named by their
    smallest starting region id; in rounds every region with fewer than
    ``min_size`` points picks, among the regions it touches (a graph edge) and lies
    on (the median over those edges of |N_h . (p - q)| is at most the reach: the
    median over the points of the distance to their farthest neighbour), the one
    whose union adds the least 2 (|S_a| + |S_b| - |S_a + S_b|) (ties: smaller
    name); all picks join at once, until no small region picks."""
    lab = np.asarray(labels)
    reach = np.median(
        [max(np.linalg.norm(points[q] - points[p]) for q in lists[p]) for p in range(lab.size)]
    )
    name = {int(r): int(r) for r in np.unique(lab)}  # starting region -> its group

    def group_of(p):
        return name[int(lab[p])]

    while True:
        members = {}
        for p in range(lab.size):
            members.setdefault(group_of(p), []).append(p)
        groups = sorted(members)
        s = {g: np.sum([weights[p] * normals[p] for p in members[g]], axis=0) for g in groups}
        picks = {}
        for g in groups:
            if len(members[g]) >= min_size:
                continue
            costs = []
            for h in sorted({group_of(q) for p in members[g] for q in lists[p]} - {g}):
                n_h = s[h] / np.linalg.norm(s[h])
                gaps = [
                    abs(n_h @ (points[p] - points[q]))
                    for p in members[g]
                    for q in lists[p]
                    if group_of(q) == h
                ]
                if np.median(gaps) <= reach:
                    cost = np.linalg.norm(s[g]) + np.linalg.norm(s[h]) - np.linalg.norm(s[g] + s[h])
                    costs.append((cost, h))
            if costs:
                picks[g] = min(costs)[1]
        if not picks:
            break
        parent = {g: g for g in groups}
        for g, h in picks.items():
            a, b = _find(parent, g), _find(parent, h)
            parent[max(a, b)] = min(a, b)
        name = {r: _find(parent, g) for r, g in name.items()}
    return np.array([group_of(p) for p in range(lab.size)])


def _find(parent, g):
    while parent[g] != g:
        g = parent[g]
    return g


def farthest_neighbor_reference(lists, points):
    """Distance from every point to its farthest neighbour in ``lists`` (0 without one)."""
    far = [
        max((np.linalg.norm(points[q] - points[p]) for q in lst), default=0.0)
        for p, lst in enumerate(lists)
    ]
    return np.array(far)
