"""The switch step (thesis 4.3.2): boundary points move to the neighbouring region
whose proxy fits them best, with the sums W, S and the foreign counts updated in place.
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from ..._core._threads import run_chunks

#: `batch_switch_bounded`'s points per piece at least (`run_chunks`): most points are
#: skipped on their memo in a few nanoseconds, so a piece's dispatch would cost more
#: than its points (VSA of `decimate_mesh` on a 21,568-triangle mesh, 199 switch
#: steps, two threads: 0.067 s in 16 pieces a step, 0.058 s in 2; one thread 0.055 s).
SWITCH_PIECE = 8192


def _compact_moves(target):
    """Positions with target >= 0 (increasing) and their targets."""
    pos = np.flatnonzero(target >= 0)
    return pos, target[pos]


@njit(cache=True, inline="always")
def _dot_proxy(normals, proxy_normals, i, h):
    """n_i . N_h."""
    return (
        normals[i, 0] * proxy_normals[h, 0]
        + normals[i, 1] * proxy_normals[h, 1]
        + normals[i, 2] * proxy_normals[h, 2]
    )


@njit(cache=True, inline="always")
def _beats(d, h, li, best, best_label):
    """Whether region h with n_i . N_h = d beats the best so far: a larger d, or an
    equal one with the smaller label (the own region li is kept on a tie with it)."""
    return d > best or (d == best and best_label != li and h < best_label)


@njit(cache=True, inline="always")
def _consider(d, h, li, best, best_label, top, low):
    """One foreign region h with n_i . N_h = d: the best label (largest d, ties to
    the smaller label, own region li kept on a tie with it), the largest and the
    smallest d seen."""
    if d > top:
        top = d
    if d < low:
        low = d
    if _beats(d, h, li, best, best_label):
        best = d
        best_label = h
    return best, best_label, top, low


def batch_switch(
    indptr,
    indices,
    normals,
    weights,
    labels,
    proxy_normals,
    foreign,
    min_gain,
    candidates,
):
    """Every boundary point moves to the neighbouring region whose proxy fits best.

    With the proxy normals fixed the energy is a sum of per-point terms
    w_i |n_i - N_l|^2 = 2 w_i (1 - n_i . N_l), so all strictly improving moves can
    be applied at once. Only the ``candidates`` (increasing point
    indices) with ``foreign[i] > 0`` (a neighbour in another region) are looked
    at; the decisions are independent, so they run in parallel. Ties go to the
    smaller region label. Returns the moved points (increasing) and their new
    labels; ``labels`` is not changed.
    """
    args = (indptr, indices, normals, weights, labels, proxy_normals, foreign, min_gain)
    pos, new = _compact_moves(_switch_targets(*args, candidates))
    return candidates[pos], new


@njit(cache=True, parallel=True)
def _switch_targets(
    indptr,
    indices,
    normals,
    weights,
    labels,
    proxy_normals,
    foreign,
    min_gain,
    candidates,
):
    """`batch_switch`'s decisions: per candidate its new label, or -1 to stay."""
    nc = candidates.shape[0]
    target = np.full(nc, -1, dtype=np.int64)
    for s in prange(nc):
        i = candidates[s]
        if foreign[i] == 0:
            continue
        li = labels[i]
        cur = _dot_proxy(normals, proxy_normals, i, li)
        best = cur
        best_label = li
        for t in range(indptr[i], indptr[i + 1]):
            h = labels[indices[t]]
            if h == li:
                continue
            d = _dot_proxy(normals, proxy_normals, i, h)
            if _beats(d, h, li, best, best_label):
                best = d
                best_label = h
        if best_label != li and 2.0 * weights[i] * (best - cur) > min_gain:
            target[s] = best_label
    return target


@njit(cache=True, nogil=True)
def _switch_points(
    indptr,
    indices,
    normals,
    weights,
    labels,
    proxy_normals,
    foreign,
    min_gain,
    drift,
    memo,
    target,
    i0,
    i1,
):
    """`batch_switch_bounded` for the points i0 .. i1 - 1 (serial; the GIL released,
    so `run_chunks` runs pieces of the points on several threads at once): sets
    ``target[i]`` for a point that moves and refreshes its ``memo`` row."""
    for i in range(i0, i1):
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


def batch_switch_bounded(
    indptr,
    indices,
    normals,
    weights,
    labels,
    proxy_normals,
    foreign,
    min_gain,
    drift,
    memo,
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
    Returns moved points (increasing) and new labels. The points are decided in
    pieces, each one call of `_switch_points`, on Python threads (`run_chunks`): a
    parallel loop without numba's ``parallel=True``, whose compile cost 1.4
    CPU-seconds; every point's decision and memo row are its own, so the result
    does not depend on the threads.
    """
    n = labels.shape[0]
    target = np.full(n, -1, dtype=np.int64)
    args = (indptr, indices, normals, weights, labels, proxy_normals, foreign, min_gain)
    run_chunks(_switch_points, n, (*args, drift, memo, target), SWITCH_PIECE)
    return _compact_moves(target)


@njit(cache=True, inline="always")
def _over(w, s0, s1, s2, eta, min_cos, use_angle):
    """The split test of one region (`over_threshold`): L21 = 2 (W - |S|) > eta, or
    (``use_angle``) mean cosine |S| / W < min_cos."""
    length = np.sqrt(s0 * s0 + s1 * s1 + s2 * s2)
    return (length < min_cos * w) if use_angle else (2.0 * (w - length) > eta)


@njit(cache=True)
def hold_under_threshold(moved, new, labels, wsum, ssum, weights, wn, eta, min_cos, use_angle):
    """Which switch moves to keep so that no region is pushed over the split
    threshold (the local VSA mode, docs/decisions/segment.md "Local mode").

    ``moved, new`` are the moves of a switch (in the order `apply_moves` applies
    them), ``wsum, ssum`` the sums before them. A region that is not over the
    threshold (``eta``, or ``min_cos`` with ``use_angle``) before the moves must
    not be over it after them, unless it is left empty. Moves into or out of a
    region that would be are dropped, and the test repeats on the moves kept
    (dropping a move can push its source region over) until every region holds;
    the kept moves only shrink, so this ends. The trial sums are formed with the
    operations of `apply_moves` in its order, so the test sees the sums the run
    will hold. Returns a boolean mask over the moves (nothing is changed).
    """
    nm = moved.shape[0]
    keep = np.ones(nm, dtype=np.bool_)
    m = wsum.shape[0]
    was_over = np.zeros(m, dtype=np.bool_)
    for t in range(nm):
        for r in (labels[moved[t]], new[t]):
            was_over[r] = _over(
                wsum[r], ssum[r, 0], ssum[r, 1], ssum[r, 2], eta, min_cos, use_angle
            )
    trial_w = np.empty(m)  # only the touched regions are read and written
    trial_s = np.empty((m, 3))
    while True:
        for t in range(nm):  # reset the touched regions
            for r in (labels[moved[t]], new[t]):
                trial_w[r] = wsum[r]
                for d in range(3):
                    trial_s[r, d] = ssum[r, d]
        for t in range(nm):
            if keep[t]:
                p = moved[t]
                a = labels[p]
                b = new[t]
                trial_w[a] -= weights[p]
                trial_w[b] += weights[p]
                for d in range(3):
                    trial_s[a, d] -= wn[p, d]
                    trial_s[b, d] += wn[p, d]
        dropped = False
        for t in range(nm):
            if not keep[t]:
                continue
            for r in (labels[moved[t]], new[t]):
                if (
                    not was_over[r]
                    and trial_w[r] > 0.0
                    and _over(
                        trial_w[r],
                        trial_s[r, 0],
                        trial_s[r, 1],
                        trial_s[r, 2],
                        eta,
                        min_cos,
                        use_angle,
                    )
                ):
                    keep[t] = False
                    dropped = True
        if not dropped:
            return keep


@njit(cache=True)
def renumber_memo(memo, remap):
    """Renumber the foreign-region ids of the examined points after a merge."""
    for i in range(memo.shape[0]):
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
        cur = _dot_proxy(normals, proxy_normals, i, li)
        for t in range(indptr[i], indptr[i + 1]):
            h = labels[indices[t]]
            if h == li:
                continue
            d = _dot_proxy(normals, proxy_normals, i, h)
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
