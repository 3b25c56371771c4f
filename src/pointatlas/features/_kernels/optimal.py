"""The optimal (a, b, k) search of thesis Eq. 5.9 (numba; validated input assumed).

`optimal_kernel` visits the points in blocks; per point it runs the stages below,
each a small function inlined into the loop (``inline="always"``: the compiled
code is the loop written out, so the stages cost no calls):

1. `_offsets_and_angles`: neighbour coordinates relative to the point and the
   angles to the neighbours' normals;
2. `_pair_weights`: the weights of every (a, b) pair, pairs that select the same
   neighbours as an earlier one dropped;
3. `_prefix_means` and `_candidate_covariances`: running moment sums over k, one
   covariance per candidate choice (k, pair);
4. `_table_survivors`: the closed form's first stage for every candidate and, for
   E_dim, the certified table bound (`edim_table`) that rules most out;
5. `_survivor_ratios`: the closed form's last stages and the criterion's ratios;
6. `_best_choice`: log-free chord bounds, then the exact criterion where needed;
7. `_winner_row`: the winner's features (`eigen_features_row`, as in the fixed-k
   kernel).

Plain-numpy reference: ``tests/features/reference.py``.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from ..._core._prefetch import prefetch_read, prefetch_write
from ...normals._kernels.eig3 import lanes_stage1, lanes_stage2, lanes_stage3
from .covariance import add_moments, cov_from_sums, gather_offsets, three_distinct_k
from .formulas import edim_of, eigen_features_row, lps_ratios
from .layout import (
    AHEAD,
    BLOCK,
    N_OUT,
    OUT_E_DIM,
    REASON_FEW_DISTINCT,
    REASON_NONFINITE,
    REASON_OK,
    REASON_ZERO_EIGENSUM,
)
from .math_helpers import chord_bound, normal_angle, sigmoid_ramp, xlogx

__all__ = ["optimal_kernel"]

#: absolute margin (in criterion units) a lower bound must clear to skip a choice
_PRUNE_MARGIN = 1e-9


@njit(cache=True, inline="always", error_model="numpy")
def _prefetch_ahead(points, normals, idx, order, out, t, t_end, kmax, use_normals):
    """Prefetch the index and output rows `AHEAD` points later and the neighbour
    coordinates (and normals) `AHEAD` / 2 points later."""
    if t + AHEAD < t_end:
        ia = order[t + AHEAD]
        for c in range(0, kmax, 8):
            prefetch_read(idx, ia, c)
        prefetch_read(idx, ia, kmax - 1)
        prefetch_write(out, ia, 0)
        prefetch_write(out, ia, N_OUT - 1)
    if t + AHEAD // 2 < t_end:
        ib = order[t + AHEAD // 2]
        for j in range(kmax):
            prefetch_read(points, idx[ib, j], 0)
            if use_normals:
                prefetch_read(normals, idx[ib, j], 0)


@njit(cache=True, inline="always", error_model="numpy")
def _no_choice(out, i):
    """Row i of a point without a valid choice: NaN, E_dim +inf."""
    for c in range(N_OUT):
        out[i, c] = np.nan
    out[i, OUT_E_DIM] = np.inf


@njit(cache=True, inline="always", error_model="numpy")
def _offsets_and_angles(points, normals, idx, i, kmax, use_normals, offsets, nbr_normals, angles):
    """Stage 1: ``offsets`` (kmax, 3) of the neighbours from point i and, with
    normals, their ``angles`` (kmax,) to its normal (`normal_angle`, as
    `angles_kernel`); False when anything is non-finite."""
    ok = gather_offsets(points, idx, i, kmax, offsets)
    if use_normals:
        nx = normals[i, 0]
        ny = normals[i, 1]
        nz = normals[i, 2]
        # the neighbours' normals first, then the angles in a flat loop
        # (vectorised; x is NaN or in [0, pi])
        for j in range(kmax):
            m = idx[i, j]
            nbr_normals[0, j] = normals[m, 0]
            nbr_normals[1, j] = normals[m, 1]
            nbr_normals[2, j] = normals[m, 2]
        n_bad = 0
        for j in range(kmax):
            x = normal_angle(nx, ny, nz, nbr_normals[0, j], nbr_normals[1, j], nbr_normals[2, j])
            angles[j] = x
            n_bad += 0 if x == x else 1
        if n_bad > 0:
            ok = False
    return ok


@njit(cache=True, inline="always", error_model="numpy")
def _pair_weights(
    angles,
    kmax,
    use_normals,
    pair_a,
    pair_b,
    n_pairs,
    dedupe,
    all_bits,
    weights,
    active,
    seen_masks,
    ramp,
    ramp_pairs,
):
    """Stage 2: the weights (n_pairs, kmax) of the active pairs; returns their number.

    For every distinct a the neighbours with angle <= a (a bit mask) and the
    smallest angle above a are found; a pair (a, b) whose weights are then all 0/1
    and select the same neighbours as an earlier pair is dropped (identical
    values; the earlier pair wins the tie). Only the remaining pairs, listed in
    ``active``, get their weights: 0/1, or the cosine ramp (`sigmoid_ramp`, the
    weights of `cosine_sigmoid_scalar`) where an angle lies in (a, b). Without
    normals the one pair keeps its weights of 1.
    """
    x_max = 0.0
    if use_normals:
        for j in range(kmax):
            x = angles[j]
            x_max = x if x > x_max else x_max
    n_active = 0
    n_masks = 0
    n_ramp = 0
    a_prev = np.nan
    mask = np.uint64(0)
    x_next = np.inf
    for pr in range(n_pairs):
        if use_normals:
            a = pair_a[pr]
            b = pair_b[pr]
            if a != a_prev:
                # neighbours with weight 1 (angle <= a) and the next angle
                # (branch-free: the angles are not NaN here); from the
                # largest angle on, every neighbour has weight 1
                a_prev = a
                mask = all_bits
                x_next = np.inf
                if a < x_max:
                    mask = np.uint64(0)
                    for j in range(kmax):
                        x = angles[j]
                        c = x if x > a else np.inf
                        x_next = c if c < x_next else x_next
                    if dedupe:
                        for j in range(kmax):
                            bit = np.uint64(1) if angles[j] <= a else np.uint64(0)
                            mask |= bit << np.uint64(j)
            binary = x_next >= b  # no angle in (a, b): weights 0/1
            if dedupe and binary:
                seen = False
                for mm in range(n_masks):
                    if seen_masks[mm] == mask:
                        seen = True
                        break
                if seen:
                    continue
                seen_masks[n_masks] = mask
                n_masks += 1
            if binary:
                for j in range(kmax):
                    weights[pr, j] = 1.0 if angles[j] <= a else 0.0
            else:
                # the ramp's argument now, the ramp below for all such pairs
                inv = 1.0 / (b - a)
                base = n_ramp * kmax
                for j in range(kmax):
                    ramp[base + j] = (angles[j] - a) * inv
                ramp_pairs[n_ramp] = pr
                n_ramp += 1
        active[n_active] = pr
        n_active += 1
    # the cosine ramps of every pair with angles inside (a, b) in one flat
    # loop (vectorised, and the polynomials of different pairs overlap)
    for u in range(n_ramp * kmax):
        ramp[u] = sigmoid_ramp(ramp[u])
    for u in range(n_ramp):
        pr = ramp_pairs[u]
        a = pair_a[pr]
        b = pair_b[pr]
        for j in range(kmax):
            x = angles[j]
            w = ramp[u * kmax + j]
            w = 0.0 if x >= b else w
            w = 1.0 if x <= a else w
            weights[pr, j] = w
    return n_active


@njit(cache=True, inline="always", error_model="numpy")
def _prefix_means(offsets, kmin, kmax, mean_k, finite_k):
    """Stage 3a: unweighted barycentres (3, nk) of the k nearest neighbours for
    every k in [kmin, kmax], and whether their sums are finite."""
    ux = 0.0
    uy = 0.0
    uz = 0.0
    for j in range(kmax):
        ux += offsets[j, 0]
        uy += offsets[j, 1]
        uz += offsets[j, 2]
        k = j + 1
        if k >= kmin:
            mean_k[0, k - kmin] = ux / k
            mean_k[1, k - kmin] = uy / k
            mean_k[2, k - kmin] = uz / k
            finite_k[k - kmin] = math.isfinite(ux + uy + uz)


@njit(cache=True, inline="always", error_model="numpy")
def _candidate_covariances(
    weights, active, n_active, offsets, kmin, kmax, mean_k, cand_cov, cand_k, cand_pair
):
    """Stage 3b: prefix moments of every active pair at every k >= kmin; returns the
    number of candidates.

    Pair by pair with the ten sums in registers (the same additions in the same
    order as one running update per neighbour); only the choices with at least
    three distinct weighted points are kept, as candidates q with covariance
    ``cand_cov[:, q]`` (c00, c01, c02, c11, c12, c22, from `cov_from_sums`), k
    ``cand_k[q]`` and pair ``cand_pair[q]``.
    """
    n_cand = 0
    for s in range(n_active):
        pr = active[s]
        # candidates from the first k with three distinct weighted points
        ks = max(three_distinct_k(weights, pr, offsets, kmax), kmin)
        if ks > kmax:
            continue
        s0 = s1 = s2 = s3 = s4 = s5 = s6 = s7 = s8 = s9 = 0.0
        for j in range(kmax):
            w = weights[pr, j]
            yx = offsets[j, 0]
            yy = offsets[j, 1]
            yz = offsets[j, 2]
            s0, s1, s2, s3, s4, s5, s6, s7, s8, s9 = add_moments(
                w, yx, yy, yz, s0, s1, s2, s3, s4, s5, s6, s7, s8, s9
            )
            if j + 1 >= ks:
                q = n_cand
                n_cand += 1
                c = cov_from_sums(
                    s0,
                    s1,
                    s2,
                    s3,
                    s4,
                    s5,
                    s6,
                    s7,
                    s8,
                    s9,
                    mean_k[0, j + 1 - kmin],
                    mean_k[1, j + 1 - kmin],
                    mean_k[2, j + 1 - kmin],
                )
                cand_cov[0, q] = c[0]
                cand_cov[1, q] = c[1]
                cand_cov[2, q] = c[2]
                cand_cov[3, q] = c[3]
                cand_cov[4, q] = c[4]
                cand_cov[5, q] = c[5]
                cand_k[q] = j + 1
                cand_pair[q] = pr
    return n_cand


@njit(cache=True, inline="always", error_model="numpy")
def _table_survivors(
    cand_cov,
    n_cand,
    use_tab,
    tab_flat,
    n_rho,
    n_v,
    stage1,
    cand_cell,
    cand_bound,
    survivors,
    surv_stage1,
):
    """Stage 4: the closed form's first stage of every candidate into ``stage1``
    (q, p, p^2, r) and, for E_dim with a table, the survivors of its bounds;
    returns their number.

    Each candidate's (p/q, sqrt(1 + r)) cell of `edim_table` holds a certified
    lower bound of its E_dim; only the candidates whose bound does not exceed the
    exact E_dim of the one with the smallest bound (plus `_PRUNE_MARGIN`) go on
    (NaN passes). Survivor s is candidate ``survivors[s]``, its stage-1 values
    copied into ``surv_stage1[:, s]``. Without a table every candidate survives.
    """
    for q in range(n_cand):
        stage1[0, q], stage1[1, q], stage1[2, q], stage1[3, q] = lanes_stage1(
            cand_cov[0, q],
            cand_cov[1, q],
            cand_cov[2, q],
            cand_cov[3, q],
            cand_cov[4, q],
            cand_cov[5, q],
        )
    n_surv = 0
    upper = np.inf
    if use_tab and n_cand > 0:
        # the cell of each candidate as a float (the loop vectorises; AVX2 has
        # no 64-bit integer product), bad ones: the table's last entry, -inf
        v_scale = n_v / math.sqrt(2.0)
        fv_max = float(n_v - 1)
        n_cells = float(n_rho * n_v)
        for q in range(n_cand):
            rho = stage1[1, q] / stage1[0, q]
            v1 = math.sqrt(1.0 + stage1[3, q])
            good = rho >= 0.0 and rho < 1.0 and stage1[2, q] > 0.0 and v1 <= 2.0
            fr = np.floor(rho * n_rho)
            fv = np.floor(v1 * v_scale)
            fv = fv_max if fv > fv_max else fv
            cand_cell[q] = fr * n_v + fv if good else n_cells
        t_min = np.inf
        for q in range(n_cand):
            tq = tab_flat[int(cand_cell[q])]
            cand_bound[q] = tq
            t_min = tq if tq < t_min else t_min
        q0 = 0
        for q in range(n_cand):
            if cand_bound[q] == t_min:
                q0 = q
                break
        v1, h1, v3, h3 = lanes_stage2(stage1[3, q0])
        l1, l2, l3 = lanes_stage3(stage1[0, q0], stage1[1, q0], stage1[2, q0], v1, h1, v3, h3)
        lin, pla, sca = lps_ratios(l1, l2, l3)
        upper = edim_of(lin, pla, sca) + _PRUNE_MARGIN
    for q in range(n_cand):
        survivors[n_surv] = q
        n_surv += 0 if (use_tab and cand_bound[q] > upper) else 1
    for s in range(n_surv):
        q = survivors[s]
        surv_stage1[0, s] = stage1[0, q]
        surv_stage1[1, s] = stage1[1, q]
        surv_stage1[2, s] = stage1[2, q]
        surv_stage1[3, s] = stage1[3, q]
    return n_surv


@njit(cache=True, inline="always", error_model="numpy")
def _survivor_ratios(surv_stage1, n_surv, criterion, stage2, surv_eig, surv_ratios):
    """Stage 5: the closed form's last stages for the survivors, their eigenvalues
    ``surv_eig`` (3, n) and the arguments of -t ln t in the criterion
    ``surv_ratios`` (3, n), as the criterion computes them."""
    for s in range(n_surv):
        stage2[0, s], stage2[1, s], stage2[2, s], stage2[3, s] = lanes_stage2(surv_stage1[3, s])
    for s in range(n_surv):
        l1, l2, l3 = lanes_stage3(
            surv_stage1[0, s],
            surv_stage1[1, s],
            surv_stage1[2, s],
            stage2[0, s],
            stage2[1, s],
            stage2[2, s],
            stage2[3, s],
        )
        surv_eig[0, s] = l1
        surv_eig[1, s] = l2
        surv_eig[2, s] = l3
        if criterion == 1:
            sm = l1 + l2 + l3
            surv_ratios[0, s] = l1 / sm
            surv_ratios[1, s] = l2 / sm
            surv_ratios[2, s] = l3 / sm
        else:
            surv_ratios[0, s], surv_ratios[1, s], surv_ratios[2, s] = lps_ratios(l1, l2, l3)


@njit(cache=True, inline="always", error_model="numpy")
def _best_choice(
    surv_eig, surv_ratios, n_surv, criterion, survivors, cand_k, cand_pair, surv_bound
):
    """Stage 6: the argmin of the criterion over the survivors.

    A logarithm-free lower bound (chords of -t ln t, `chord_bound`) per survivor;
    the smallest bound first, then only survivors whose bound does not exceed the
    best value found so far by `_PRUNE_MARGIN` get the criterion with its three
    logarithms. Ties: smallest k, then pair. Returns (reason if none, k, pair,
    candidate) with k = -1 when no survivor has lambda_1 > 0.
    """
    n_zero = 0
    for q in range(n_surv):
        r0 = surv_ratios[0, q]
        r1 = surv_ratios[1, q]
        r2 = surv_ratios[2, q]
        lb = chord_bound(r0) + chord_bound(r1) + chord_bound(r2)
        zero = not surv_eig[0, q] > 0.0  # lambda_1 = 0: no choice
        surv_bound[q] = np.inf if zero else lb
        n_zero += 1 if zero else 0
    code = REASON_ZERO_EIGENSUM if n_zero > 0 else REASON_FEW_DISTINCT
    lb0 = np.inf
    for q in range(n_surv):
        lb0 = surv_bound[q] if surv_bound[q] < lb0 else lb0
    q0 = -1
    if lb0 < np.inf:
        for q in range(n_surv):
            if surv_bound[q] == lb0:
                q0 = q
                break
    best_val = np.inf
    bk = -1
    bp = -1
    bq = -1
    if q0 >= 0:
        for step in range(n_surv + 1):
            q = q0 if step == 0 else step - 1
            if step > 0 and (q == q0 or not surv_bound[q] <= best_val + _PRUNE_MARGIN):
                continue
            r0 = surv_ratios[0, q]
            r1 = surv_ratios[1, q]
            r2 = surv_ratios[2, q]
            if criterion == 1:
                val = -(xlogx(r0) + xlogx(r1) + xlogx(r2))
            else:
                val = edim_of(r0, r1, r2)
            k = cand_k[survivors[q]]
            pr = cand_pair[survivors[q]]
            if val < best_val or (val == best_val and (k < bk or (k == bk and pr < bp))):
                best_val = val
                bk = k
                bp = pr
                bq = survivors[q]
    return code, bk, bp, bq


@njit(cache=True, inline="always", error_model="numpy")
def _winner_row(out, i, cand_cov, bq, finite, m1, m2):
    """Stage 7: row i of ``out`` from the winning candidate ``bq``; returns the reason.

    The winner's covariance is its stored one (`cov_from_sums`): the very numbers
    `choice_cov` (`fused_kernel`) computes at this choice (same weights, sums and
    formula); its eigen-decomposition and features follow (`eigen_features_row`).
    Non-finite when the barycentre's sums at the winner's k are not finite.
    """
    if not finite:
        return REASON_NONFINITE
    if not eigen_features_row(
        out,
        i,
        cand_cov[0, bq],
        cand_cov[1, bq],
        cand_cov[2, bq],
        cand_cov[3, bq],
        cand_cov[4, bq],
        cand_cov[5, bq],
        m1,
        m2,
    ):
        return REASON_ZERO_EIGENSUM
    return REASON_OK


@njit(cache=True, error_model="numpy")
def _flat_table(tab):
    """`edim_table` flat, with -inf (no bound) at its end for choices outside it."""
    n_cells = tab.shape[0] * tab.shape[1]
    tab_flat = np.full(n_cells + 1, -np.inf)
    tab_flat[:n_cells] = tab.ravel()
    return tab_flat


@njit(parallel=True, cache=True, error_model="numpy")
def optimal_kernel(
    points,
    normals,
    idx,
    order,
    kmin,
    kmax,
    use_normals,
    pair_a,
    pair_b,
    criterion,
    m1,
    m2,
    out,
    reason,
    best_k,
    best_pair,
    tab,
):
    """Optimal (a, b, k) per point (Eq. 5.9) by running moment sums over k, and its features.

    Points are visited in blocks, in ``order`` (`pointatlas._core._sort.morton_order`);
    per point the stages of the module docstring run in order: the angles to the
    kmax sorted neighbours' normals once; the weights of every (a, b) pair
    (duplicates dropped); weighted moments (sum w, sum w y, sum w y y^T about the
    point) growing by one neighbour per k, so each covariance costs O(1); the
    eigenvalues of all stored covariances by `eig3_fast`'s closed form, copied
    branch-free into three flat loops the compiler vectorises (`lanes_stage1` to
    `lanes_stage3`). For E_dim (criterion 0) with a table ``tab`` (`edim_table`)
    only the choices its certified bounds do not rule out go past the first stage;
    chord bounds then spare most of the rest their logarithms. Every choice skipped
    is certified worse, so the result is the exact argmin of the criterion over all
    choices. Ties: smallest k, then a, then b. Criterion 1: eigenentropy (``tab`` of
    shape (0, 0): every choice goes through all stages). Without normals there is
    one pair with all weights 1.

    Row i of ``out`` (N, `N_OUT`) receives the winner's eigen-decomposition and
    features (`_winner_row`), so the result equals the search followed by
    `fused_kernel` at the chosen triple bit for bit, without the angle table and
    the second pass. ``reason``, ``best_k`` (-1: none) and ``best_pair`` (-1) per
    point; rows without a valid choice are NaN (E_dim +inf). Indices must lie in
    [0, N).

    Length: the body is the per-block scratch arrays, each named with its role
    (allocated inside the ``prange`` loop, so one set per thread), and the stage
    calls; a helper returning the twenty arrays would only move their names.
    """
    n = idx.shape[0]
    n_pairs = pair_a.shape[0] if use_normals else 1
    dedupe = use_normals and kmax <= 64
    # the mask of all kmax neighbours (bit j: neighbour j)
    all_bits = np.uint64(0xFFFFFFFFFFFFFFFF) >> np.uint64(64 - min(kmax, 64))
    nk = kmax - kmin + 1
    n_choices = nk * n_pairs
    nblocks = (n + BLOCK - 1) // BLOCK
    n_rho, n_v = tab.shape
    tab_flat = _flat_table(tab)
    use_tab = criterion == 0 and n_rho * n_v > 0
    for blk in prange(nblocks):
        # per point: neighbour offsets from the point, their normals, their angles
        offsets = np.empty((kmax, 3))
        nbr_normals = np.empty((3, kmax))
        angles = np.zeros(kmax)
        # per pair: weights, the active pairs, masks seen, pairs with a ramp
        weights = np.ones((n_pairs, kmax))
        active = np.empty(n_pairs, dtype=np.int64)
        seen_masks = np.empty(n_pairs, dtype=np.uint64)
        ramp_pairs = np.empty(n_pairs, dtype=np.int64)
        ramp = np.empty(n_pairs * kmax)
        # per k: unweighted barycentre and whether it is finite
        mean_k = np.empty((3, nk))
        finite_k = np.empty(nk, dtype=np.bool_)
        # per candidate choice q: covariance, k, pair, table cell and bound, stage 1
        cand_cov = np.empty((6, n_choices))
        cand_k = np.empty(n_choices, dtype=np.int64)
        cand_pair = np.empty(n_choices, dtype=np.int64)
        cand_cell = np.empty(n_choices)
        cand_bound = np.empty(n_choices)
        stage1 = np.empty((4, n_choices))
        # per survivor s: its candidate, closed-form stages, eigenvalues, ratios, bound
        survivors = np.empty(n_choices, dtype=np.int64)
        surv_stage1 = np.empty((4, n_choices))
        stage2 = np.empty((4, n_choices))
        surv_eig = np.empty((3, n_choices))
        surv_ratios = np.empty((3, n_choices))
        surv_bound = np.empty(n_choices)
        t_end = min(n, (blk + 1) * BLOCK)
        for t in range(blk * BLOCK, t_end):
            _prefetch_ahead(points, normals, idx, order, out, t, t_end, kmax, use_normals)
            i = order[t]
            best_k[i] = -1
            best_pair[i] = -1
            if not _offsets_and_angles(
                points, normals, idx, i, kmax, use_normals, offsets, nbr_normals, angles
            ):
                reason[i] = REASON_NONFINITE
                _no_choice(out, i)
                continue
            n_active = _pair_weights(
                angles,
                kmax,
                use_normals,
                pair_a,
                pair_b,
                n_pairs,
                dedupe,
                all_bits,
                weights,
                active,
                seen_masks,
                ramp,
                ramp_pairs,
            )
            _prefix_means(offsets, kmin, kmax, mean_k, finite_k)
            n_cand = _candidate_covariances(
                weights, active, n_active, offsets, kmin, kmax, mean_k, cand_cov, cand_k, cand_pair
            )
            n_surv = _table_survivors(
                cand_cov,
                n_cand,
                use_tab,
                tab_flat,
                n_rho,
                n_v,
                stage1,
                cand_cell,
                cand_bound,
                survivors,
                surv_stage1,
            )
            _survivor_ratios(surv_stage1, n_surv, criterion, stage2, surv_eig, surv_ratios)
            code, bk, bp, bq = _best_choice(
                surv_eig, surv_ratios, n_surv, criterion, survivors, cand_k, cand_pair, surv_bound
            )
            if bk >= 0:  # else code is the reason no choice is valid
                code = _winner_row(out, i, cand_cov, bq, finite_k[bk - kmin], m1, m2)
            reason[i] = code
            if code == REASON_OK:
                best_k[i] = bk
                best_pair[i] = bp
            else:
                _no_choice(out, i)
