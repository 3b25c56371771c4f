"""The steps of one `vsa_segment` run: flood, split, merge, switch, the classic
loop and the final relabelling (thesis 4.2-4.3). Private; inputs validated.

`_VSARun` holds the state a run shares between its steps (labels, per-region
sums, the switch's and the merge's bookkeeping, the energy history); every
step is one method. `vsa_segment` builds one, runs it and turns it into a
`VSAResult`.
"""

from __future__ import annotations

import math
import time

import numpy as np

from .._core.tolerances import (
    VSA_LOCAL_MERGE_FACTOR,
    VSA_MERGE_FULL_SCAN_SHARE,
    VSA_MERGE_ROUNDS,
    VSA_SWITCH_MIN_GAIN,
)
from ._kernels import (
    apply_moves,
    batch_switch_bounded,
    best_points,
    best_single_move,
    boundary_points,
    canonical_labels,
    connected_label_components,
    edge_pairs,
    farthest_neighbor_distances,
    flood,
    foreign_counts,
    forget_around,
    greedy_merge,
    hold_under_threshold,
    merge_candidate_pairs,
    recount_foreign,
    region_pairs,
    renumber_memo,
    touched_points,
)
from ._sums import (
    energy_fixed,
    energy_opt,
    labels_key,
    over_threshold,
    proxy_normals,
    region_costs,
    region_sums,
    row_norms,
)


def split_regions(points, w, labels, m, over):
    """Cut every region over the threshold by the plane through its weighted
    centroid orthogonal to its direction of largest weighted spread (4.3.3 a).

    ``over`` flags the regions to cut; returns the points that move, their new
    labels (new regions m, m+1, ...) and the number of cuts (regions that cannot
    be cut, e.g. all points coincide, are left alone).
    """
    idx = np.flatnonzero(over[labels])
    lab = labels[idx]
    ww = w[idx].copy()
    wr = np.bincount(lab, weights=ww, minlength=m)
    ww[wr[lab] <= 0.0] = 1.0  # all-zero weights: plain PCA
    wr = np.bincount(lab, weights=ww, minlength=m)
    counts = np.bincount(lab, minlength=m)
    p = points[idx]
    regs = np.flatnonzero(over & (wr > 0.0))  # a region without points has no centroid
    cen = np.zeros((m, 3))
    for d in range(3):
        cen[:, d] = np.bincount(lab, weights=ww * p[:, d], minlength=m)
    cen[regs] /= wr[regs, None]
    q = p - cen[lab]
    cov = np.zeros((m, 3, 3))
    for a in range(3):
        for b in range(a, 3):
            cov[:, a, b] = np.bincount(lab, weights=ww * q[:, a] * q[:, b], minlength=m)
            cov[:, b, a] = cov[:, a, b]
    _, vecs = np.linalg.eigh(cov[regs])
    direction = np.zeros((m, 3))
    direction[regs] = vecs[:, :, 2]
    side = np.einsum("ij,ij->i", q, direction[lab]) > 0.0
    n_pos = np.bincount(lab, weights=side.astype(np.float64), minlength=m)
    ok = over & (n_pos > 0) & (n_pos < counts)
    n_new = int(ok.sum())
    new_id = np.full(m, -1, dtype=np.int64)
    new_id[ok] = m + np.arange(n_new)
    move = side & ok[lab]
    return idx[move], new_id[lab[move]], n_new


def _group_median(group, values, n_groups):
    """Median of ``values`` per group id in 0..n_groups-1 (the mean of the two
    middle values for an even count; NaN for an empty group)."""
    order = np.lexsort((values, group))
    v = values[order]
    cnt = np.bincount(group, minlength=n_groups)
    start = np.zeros(n_groups, dtype=np.int64)
    np.cumsum(cnt[:-1], out=start[1:])
    med = np.full(n_groups, np.nan)
    has = cnt > 0
    lo = start[has] + (cnt[has] - 1) // 2
    hi = start[has] + cnt[has] // 2
    med[has] = 0.5 * (v[lo] + v[hi])
    return med


def _normal_gap(points, a, b, normals):
    """|n . (p_a - p_b)| per pair: how far apart two points lie along a normal."""
    return np.abs(np.einsum("ij,ij->i", points[a] - points[b], normals))


def edge_rows(indptr) -> np.ndarray:
    """The row (point) of every entry of a CSR graph's ``indices``."""
    return np.repeat(np.arange(indptr.shape[0] - 1, dtype=np.int64), np.diff(indptr))


def neighbourhood_reach(indptr, indices, points) -> float:
    """The typical neighbourhood reach: the median over the points (with a
    neighbour) of the distance to their farthest graph neighbour."""
    far = farthest_neighbor_distances(indptr, indices, points)
    return float(np.median(far[np.diff(indptr) > 0]))


def off_surface_moves(indptr, indices, points, labels, prox, limit, rows=None):
    """The points that lie off their region's local surface and where they go
    (local mode; docs/decisions/segment.md "Local mode").

    A point's *offset* from a region is the median distance, along the region's
    proxy normal ``prox``, from the point to its graph neighbours in that region
    (how far it sits off the region's plane through its own neighbourhood; the
    median, so one stray neighbour does not decide). A point whose offset from
    its own region exceeds ``limit`` leaves it: for the neighbouring region (of a
    graph neighbour) of least offset, if that offset is at most ``limit`` (ties:
    the smaller region id), else for a region of its own (target -1). Every
    decision reads the labels before any move; a point with no neighbour in its
    region stays. Returns (moved, target), ``moved`` increasing. ``rows``: the
    graph's `edge_rows`, when the caller has them.
    """
    n = labels.shape[0]
    rows = edge_rows(indptr) if rows is None else rows
    nb_lab = labels[indices]
    same = nb_lab == labels[rows]
    r_s, q_s = rows[same], indices[same]
    gap = _normal_gap(points, r_s, q_s, prox[labels[r_s]])
    off = _group_median(r_s, gap, n)
    moved = np.flatnonzero(off > limit)  # NaN (no neighbour in the region): stays
    target = np.full(moved.shape[0], -1, dtype=np.int64)
    leave = np.zeros(n, dtype=np.bool_)
    leave[moved] = True
    e = leave[rows] & ~same
    if not e.any():
        return moved, target
    # every (leaving point, neighbouring region) pair: the median offset there
    m = prox.shape[0]
    pt_e, reg_e = rows[e], nb_lab[e]
    key, inv = np.unique(pt_e * m + reg_e, return_inverse=True)
    inv = inv.reshape(-1)
    pt, reg = key // m, key % m
    d = _normal_gap(points, pt_e, indices[e], prox[reg_e])
    o = _group_median(inv, d, key.shape[0])
    ok = o <= limit
    pt, reg, o = pt[ok], reg[ok], o[ok]
    order = np.lexsort((reg, o, pt))  # per point: least offset, then smaller region
    pt, reg = pt[order], reg[order]
    first = np.flatnonzero(np.r_[True, pt[1:] != pt[:-1]]) if pt.size else pt
    target[np.searchsorted(moved, pt[first])] = reg[first]
    return moved, target


def merge_regions(indptr, indices, labels, wsum, ssum, counts, pairs, subset, eta, min_cos):
    """Greedy cheapest-first merging on the region adjacency graph (4.3.3 b).

    ``pairs`` are the candidate region pairs of the first pass. In eta mode one
    pass is exhaustive (a rejected union stays rejected as regions grow, since
    L21 only grows with the point set). In max_angle mode (``eta`` None) a
    rejected union may become acceptable after a neighbour absorbed well-aligned
    points, so passes repeat, with the pairs joined by an edge at a point of
    ``subset`` (a superset of the boundary), until none merges. Returns labels,
    W, S, counts, the number of merges and the map from old to new region ids
    (None when nothing merged).
    """
    use_angle = eta is None
    total = 0
    remap_total = None
    while True:
        roots, n_merges = greedy_merge(
            pairs,
            wsum,
            ssum,
            float(eta) if eta is not None else 0.0,
            float(min_cos) if min_cos is not None else 0.0,
            use_angle,
        )
        if n_merges == 0:
            return labels, wsum, ssum, counts, total, remap_total
        total += int(n_merges)
        remap, m = canonical_labels(roots)
        remap_total = remap if remap_total is None else remap[remap_total]
        labels = remap[labels]
        wsum = np.bincount(remap, weights=wsum, minlength=m)
        ssum = np.stack([np.bincount(remap, weights=ssum[:, d], minlength=m) for d in range(3)], 1)
        counts = np.bincount(remap, weights=counts, minlength=m).astype(np.int64)
        if not use_angle:
            return labels, wsum, ssum, counts, total, remap_total
        pairs = region_pairs(indptr, indices, labels, subset)


class _VSARun:
    """State of one VSA run on the spatially renumbered points.

    ``indptr, indices`` the symmetric graph, ``points, normals, w`` the points,
    unit normals and weights; ``eta`` or ``min_cos`` the split/merge threshold.
    After `start` the run holds ``labels`` (0..m-1), the per-region sums
    ``wsum, ssum, counts`` and the energy history (``names, history``); the
    loop steps keep, besides, the switch's bookkeeping (``foreign`` counts, the
    ``memo`` and ``drift`` of `batch_switch_bounded`, the previous proxies) and
    the merge's (``dirty_merge``: regions whose W, S changed since the merge
    last looked at them).

    With ``local`` (`VSAOptions.local`) the switch never pushes a region over
    the threshold and merges accept a union only within ``merge_eta`` or
    ``merge_min_cos``, the threshold held to ``VSA_LOCAL_MERGE_FACTOR`` of
    itself; otherwise those equal ``eta`` and ``min_cos``.
    """

    def __init__(self, indptr, indices, points, normals, w, eta, min_cos, local=False):
        self.indptr, self.indices = indptr, indices
        self.points, self.normals, self.w = points, normals, w
        self.wn = w[:, None] * normals
        self.eta, self.min_cos = eta, min_cos
        self.local = local
        self.merge_eta, self.merge_min_cos = eta, min_cos
        if local and eta is not None:
            self.merge_eta = VSA_LOCAL_MERGE_FACTOR * eta
        elif local:
            angle = math.acos(min(1.0, min_cos))
            self.merge_min_cos = math.cos(VSA_LOCAL_MERGE_FACTOR * angle)
        self.names: list[str] = []
        self.history: list[float] = []
        self.timings: dict[str, float] = {}
        self.n_iter = 0
        self.converged = False
        self.stop_reason = "max_iter"

    def record(self, name, value):
        self.names.append(name)
        self.history.append(value)

    def _resum(self):
        self.wsum, self.ssum, self.counts = region_sums(self.labels, self.m, self.w, self.wn)

    # ------------------------------------------------------------------ start

    def start(self, seed_idx, all_seeds):
        """Initial flood from the seeds (every point its own region with
        ``all_seeds``) and proxy update."""
        t0 = time.perf_counter()
        n = self.w.shape[0]
        if all_seeds:
            self.labels = np.arange(n, dtype=np.int64)
            self.m = n
            # the sums of singletons (+ 0.0: as bincount, no -0.0)
            self.wsum, self.ssum = self.w + 0.0, self.wn + 0.0
            self.counts = np.ones(n, dtype=np.int64)
            self.record("flood", 0.0)
        else:
            self.m = seed_idx.shape[0]
            seed_normals = np.ascontiguousarray(self.normals[seed_idx])
            self.labels = flood(self.indptr, self.indices, self.normals, seed_idx, seed_normals)
            self._resum()
            self.record("flood", energy_fixed(self.wsum, self.ssum, self.normals[seed_idx]))
        self.record("update", energy_opt(self.wsum, self.ssum))
        self.timings["flood"] = time.perf_counter() - t0
        self.seen = {labels_key(self.labels): 0}
        self.singletons = all_seeds

    # ------------------------------------------------------------------ classic loop

    def run_classic(self, max_iter):
        """Classic VSA (4.2.2): re-seed at the best points, flood, update, until
        nothing changes or a labelling repeats."""
        t_flood = {}
        for it in range(max_iter):
            prox = proxy_normals(self.labels, self.wsum, self.ssum, self.counts, self.normals)
            best = best_points(self.labels, self.m, self.normals, prox)
            t0 = time.perf_counter()
            new = flood(self.indptr, self.indices, self.normals, best, prox)
            t_flood["flood"] = t_flood.get("flood", 0.0) + time.perf_counter() - t0
            self.wsum, self.ssum, self.counts = region_sums(new, self.m, self.w, self.wn)
            self.record("flood", energy_fixed(self.wsum, self.ssum, prox))
            self.record("update", energy_opt(self.wsum, self.ssum))
            self.n_iter = it + 1
            if np.array_equal(new, self.labels):
                self.converged, self.stop_reason = True, "converged"
                break
            key = labels_key(new)
            self.labels = new
            if key in self.seen:
                self.stop_reason = "cycle"
                break
            self.seen[key] = self.n_iter
        self._add_timings(t_flood)

    # ------------------------------------------------------------------ main loop

    def run_loop(self, max_iter, *, split, merge, switch):
        """Split, merge, switch and update until an iteration changes nothing.

        Merges may raise the energy, so they run only while a round of split +
        merge reduces the number of regions (at most ``VSA_MERGE_ROUNDS``
        rounds); while they run a repeated labelling ends the loop ("cycle").
        In local mode no such count over the whole input decides: merges run in
        every iteration, up to ``VSA_MERGE_ROUNDS`` rounds.
        """
        n = self.w.shape[0]
        self.foreign = foreign_counts(self.indptr, self.indices, self.labels)
        self.dirty_merge = np.ones(self.m, dtype=np.bool_)
        # batch switch bookkeeping (see batch_switch_bounded): per point the
        # margin by which it last stayed, per region the summed proxy movement
        self.memo = np.full((n, 6), np.nan)
        self.drift = np.zeros(self.m)
        self.prev_prox = None
        merging = merge
        merge_rounds = 0
        spent = {"split": 0.0, "merge": 0.0, "switch": 0.0, "update": 0.0}
        for it in range(max_iter):
            n_merge = 0
            t0 = time.perf_counter()
            n_split = self.split_step() if split else 0
            spent["split"] += time.perf_counter() - t0
            t0 = time.perf_counter()
            if merging:
                merge_rounds += 1
                n_merge = self.merge_step()
            spent["merge"] += time.perf_counter() - t0
            switched = switch != "none" and self.switch_step(switch, spent)
            self.n_iter = it + 1
            if not (n_split or n_merge or switched):
                self.converged, self.stop_reason = True, "converged"
                break
            if merging:
                # only merges can raise the energy, so only while they run can a
                # labelling repeat; afterwards the energy strictly decreases
                key = labels_key(self.labels)
                if key in self.seen:
                    self.stop_reason = "cycle"
                    break
                self.seen[key] = self.n_iter
                if merge_rounds >= VSA_MERGE_ROUNDS or (not self.local and n_merge <= n_split):
                    # split and merge no longer shrink the region count (they only
                    # trade regions, or changed nothing): from now on only split,
                    # switch and update run, which never raise the energy
                    merging = False
        self._add_timings(spent)

    def split_step(self):
        """Split every region over the threshold (4.3.3 a); returns the number of cuts."""
        over = over_threshold(self.wsum, self.ssum, self.eta, self.min_cos)
        if not over.any():
            return 0
        moved, new, n_split = split_regions(self.points, self.w, self.labels, self.m, over)
        if n_split:
            self.m += n_split
            self.wsum = np.concatenate([self.wsum, np.zeros(n_split)])
            self.ssum = np.concatenate([self.ssum, np.zeros((n_split, 3))])
            self.counts = np.concatenate([self.counts, np.zeros(n_split, dtype=np.int64)])
            grow = np.ones(n_split, dtype=np.bool_)
            self.dirty_merge = np.concatenate([self.dirty_merge, grow])
            self.dirty_merge[self.labels[moved]] = True
            self.drift = np.concatenate([self.drift, np.zeros(n_split)])
            self._move(moved, new)
            self.record("split", energy_opt(self.wsum, self.ssum))
        return n_split

    def _merge_pairs(self):
        """Candidate pairs of this merge round and the points whose edges give
        the pairs of later passes (max_angle mode)."""
        indptr, indices, labels, foreign = self.indptr, self.indices, self.labels, self.foreign
        if self.singletons:  # every point its own region: the pairs are the graph edges
            subset = np.arange(labels.shape[0], dtype=np.int64)
            return edge_pairs(indptr, indices), subset
        if self.eta is None:
            subset = np.flatnonzero(foreign)
            return region_pairs(indptr, indices, labels, subset), subset
        cost = region_costs(self.wsum, self.ssum)
        if np.count_nonzero(self.dirty_merge) > VSA_MERGE_FULL_SCAN_SHARE * self.m:
            # most regions changed: scanning every boundary point is cheaper
            # than filtering them
            near = np.flatnonzero(foreign)
        else:
            near = touched_points(indptr, indices, labels, foreign, self.dirty_merge)
        pairs = merge_candidate_pairs(
            indptr, indices, labels, foreign, self.dirty_merge, cost, self.eta, near
        )
        return pairs, None

    def merge_step(self):
        """One merge round (4.3.3 b); returns the number of merges."""
        pairs, subset = self._merge_pairs()
        labels, wsum, ssum, counts, n_merge, remap = merge_regions(
            self.indptr,
            self.indices,
            self.labels,
            self.wsum,
            self.ssum,
            self.counts,
            pairs,
            subset,
            self.merge_eta,
            self.merge_min_cos,
        )
        self.labels, self.wsum, self.ssum, self.counts = labels, wsum, ssum, counts
        self.singletons = False
        if n_merge:
            self._renumber_after_merge(remap)
            self.record("merge", energy_opt(self.wsum, self.ssum))
        # after a pass every neighbouring pair was (re)evaluated
        self.dirty_merge = np.zeros(self.m, dtype=np.bool_)
        return n_merge

    def _renumber_after_merge(self, remap):
        """Carry the switch's bookkeeping over to the merged regions ``remap``."""
        self.m = m = self.wsum.shape[0]
        # only boundary points next to a union change their count of foreign
        # neighbours; they (and only they) are examined again by the switch, the
        # others keep their memo with the regions renumbered
        joined = np.bincount(remap, minlength=m) > 1
        near = touched_points(self.indptr, self.indices, self.labels, self.foreign, joined)
        recount_foreign(self.indptr, self.indices, self.labels, self.foreign, near)
        self.memo[near, 0] = np.nan
        renumber_memo(self.memo, remap)
        self.drift = np.bincount(remap, weights=self.drift, minlength=m)
        if self.prev_prox is not None:
            mp = self.prev_prox.shape[0]
            moved_prox = np.zeros((m, 3))
            moved_prox[remap[:mp]] = self.prev_prox
            self.prev_prox = moved_prox

    def switch_step(self, mode, spent):
        """Switch (4.3.2) and proxy update; returns whether a point moved."""
        t0 = time.perf_counter()
        prox = proxy_normals(self.labels, self.wsum, self.ssum, self.counts, self.normals)
        if mode == "batch":
            if self.prev_prox is not None:
                mp = self.prev_prox.shape[0]
                self.drift[:mp] += row_norms(prox[:mp] - self.prev_prox)
            self.prev_prox = prox
            moved, new = batch_switch_bounded(
                self.indptr,
                self.indices,
                self.normals,
                self.w,
                self.labels,
                prox,
                self.foreign,
                VSA_SWITCH_MIN_GAIN,
                self.drift,
                self.memo,
            )
        else:
            point, target, gain = best_single_move(
                self.indptr, self.indices, self.normals, self.w, self.labels, prox, self.foreign
            )
            moved = new = np.empty(0, dtype=np.int64)
            if point >= 0 and gain > VSA_SWITCH_MIN_GAIN:
                moved = np.array([point], dtype=np.int64)
                new = np.array([target], dtype=np.int64)
        if self.local and moved.size:
            keep = hold_under_threshold(
                moved,
                new,
                self.labels,
                self.wsum,
                self.ssum,
                self.w,
                self.wn,
                0.0 if self.eta is None else float(self.eta),
                0.0 if self.min_cos is None else float(self.min_cos),
                self.eta is None,
            )
            moved, new = moved[keep], new[keep]
        spent["switch"] += time.perf_counter() - t0
        if not moved.size:
            return False
        t0 = time.perf_counter()
        self.dirty_merge[self.labels[moved]] = True
        self.dirty_merge[new] = True
        self._move(moved, new)
        self.record("switch", energy_fixed(self.wsum, self.ssum, prox))
        self.record("update", energy_opt(self.wsum, self.ssum))
        spent["update"] += time.perf_counter() - t0
        return True

    def _move(self, moved, new):
        """Move points to new regions: sums, counts, foreign counts in place; the
        switch memo of the points and their neighbours forgotten."""
        forget_around(self.indptr, self.indices, moved, self.memo)
        apply_moves(
            self.indptr,
            self.indices,
            self.labels,
            self.wsum,
            self.ssum,
            self.counts,
            self.foreign,
            self.w,
            self.wn,
            moved,
            new,
        )

    # ------------------------------------------------------------------ end

    def relabel_off_surface(self):
        """Local mode, after the loop: points off their region's local surface
        move (`off_surface_moves`), then every region is split into its pieces
        connected along its surface (`surface_pieces`).

        The limit is the typical neighbourhood reach: the median over the points
        of the distance to their farthest graph neighbour. A point goes to the
        neighbouring region on whose local surface it lies, else to a region of
        its own; a move into a region it would push over the threshold goes to a
        region of its own instead, and a move out of a region that would be
        pushed over stays undone (`hold_under_threshold`), so no move puts a
        region over the threshold (docs/decisions/segment.md "Local mode").
        """
        indptr, indices, pts = self.indptr, self.indices, self.points
        if not indices.size:
            return
        rows = edge_rows(indptr)
        limit = neighbourhood_reach(indptr, indices, pts)
        prox = proxy_normals(self.labels, self.wsum, self.ssum, self.counts, self.normals)
        moved, target = off_surface_moves(indptr, indices, pts, self.labels, prox, limit, rows)
        if moved.size:
            self._move_off_surface(moved, target)
            prox = proxy_normals(self.labels, self.wsum, self.ssum, self.counts, self.normals)
        self.surface_pieces(prox, limit, rows)

    def _move_off_surface(self, moved, target):
        """Apply the moves of `off_surface_moves` (target -1: a region of its own)
        that keep every region under the threshold."""
        # a move the threshold refuses (into a region it would push over) goes to
        # a region of its own instead; then only moves out of such a region drop
        eta = 0.0 if self.eta is None else float(self.eta)
        min_cos = 0.0 if self.min_cos is None else float(self.min_cos)
        own = target < 0
        for _ in range(2):
            n_new = int(own.sum())
            tgt = target.copy()
            tgt[own] = self.m + np.arange(n_new)
            wsum = np.concatenate([self.wsum, np.zeros(n_new)])
            ssum = np.concatenate([self.ssum, np.zeros((n_new, 3))])
            keep = hold_under_threshold(
                moved,
                tgt,
                self.labels,
                wsum,
                ssum,
                self.w,
                self.wn,
                eta,
                min_cos,
                self.eta is None,
            )
            if keep.all() or own[~keep].all():
                break
            own |= ~keep
        if not keep.any():
            return
        self.labels = self.labels.copy()
        self.labels[moved[keep]] = tgt[keep]
        self.labels, self.m = canonical_labels(self.labels)
        self._resum()
        self.record("off_surface", energy_opt(self.wsum, self.ssum))

    def surface_pieces(self, prox, limit, rows):
        """Split every region into its pieces connected by *surface edges*: graph
        edges inside the region whose two points lie within ``limit`` of each
        other along the region's proxy normal ``prox``. A cluster that touches a
        region only by edges that climb off its surface (vegetation above the
        ground) becomes a region of its own; the pieces are connected in the graph.
        ``rows``: the graph's `edge_rows`."""
        indices, labels = self.indices, self.labels
        keep = labels[indices] == labels[rows]
        rows, cols = rows[keep], indices[keep]
        keep = _normal_gap(self.points, rows, cols, prox[labels[rows]]) <= limit
        rows, cols = rows[keep], cols[keep]
        sub_ptr = np.zeros(labels.shape[0] + 1, dtype=np.int64)
        np.cumsum(np.bincount(rows, minlength=labels.shape[0]), out=sub_ptr[1:])
        n_before = self.m
        self.labels, self.m = connected_label_components(sub_ptr, cols, labels)
        if self.m != n_before:
            self._resum()
            self.record("relabel", energy_opt(self.wsum, self.ssum))

    def connected_pieces(self):
        """Split every region into its connected pieces (end of 4.3.2)."""
        n_before = int((self.counts > 0).sum())
        self.labels, self.m = connected_label_components(self.indptr, self.indices, self.labels)
        self._resum()
        if self.m != n_before:
            self.record("relabel", energy_opt(self.wsum, self.ssum))

    def final_merge(self):
        """Merge (cheapest first) every pair of neighbouring regions whose union
        has L21 < eta (eta mode), so no such pair remains.

        The switch moved points after the last merge round, and pieces cut off by
        the relabelling are regions of their own; unions of adjacent connected
        regions stay connected. Not in max_angle mode: the mean-deviation test
        lets a large region absorb a small perpendicular one, which no later
        split would undo.
        """
        subset = boundary_points(self.indptr, self.indices, self.labels)
        pairs = region_pairs(self.indptr, self.indices, self.labels, subset)
        labels, _, _, _, n_final, _ = merge_regions(
            self.indptr,
            self.indices,
            self.labels,
            self.wsum,
            self.ssum,
            self.counts,
            pairs,
            subset,
            self.merge_eta,
            self.merge_min_cos,
        )
        if n_final:
            self.labels, self.m = canonical_labels(labels)
            self._resum()
            self.record("final_merge", energy_opt(self.wsum, self.ssum))

    def _add_timings(self, spent):
        for key, value in spent.items():
            self.timings[key] = self.timings.get(key, 0.0) + value
