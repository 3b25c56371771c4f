"""numba kernels of the features room (validated input assumed, no checks here).

Plain-numpy references: ``tests/features/reference.py``.

Conventions shared by the kernels
---------------------------------
* ``idx`` is an (N, K) int64 neighbour table sorted by distance, the point itself in
  column 0 (what `pointatlas.neighbors.query_knn` returns).
* ``ang`` is an (N, K) float64 table of angles between the point's normal and each
  neighbour's normal (angles below ``ANGLE_ZERO`` already set to 0); kernels that
  work without normals receive a (0, 0) array and ``use_normals = False``.
* Covariances are accumulated on coordinates relative to the point itself (a
  per-point origin), so far-from-origin inputs (UTM-like LAS) keep their precision.
* Reason codes (uint8): 0 ok, 1 non-finite input, 2 all weights zero, 3 fewer than
  three distinct points carrying positive weight, 4 eigenvalue sum zero.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from .._core.tolerances import ANGLE_ZERO
from ..normals._kernels import _rotate  # the same Jacobi rotation as the normals room

__all__ = [
    "N_FEATURES",
    "angles_kernel",
    "covariance_kernel",
    "eig3_fast",
    "eig3_jacobi",
    "eigh3_accurate",
    "eigvals_batch_kernel",
    "features_kernel",
    "fused_kernel",
    "search_kernel",
    "spatial_order_kernel",
]

REASON_OK = 0
REASON_NONFINITE = 1
REASON_ZERO_WEIGHTS = 2
REASON_FEW_DISTINCT = 3
REASON_ZERO_EIGENSUM = 4

#: columns of the feature matrix written by `features_kernel`
N_FEATURES = 11
#: points per parallel block (scratch arrays are allocated once per block)
_BLOCK = 1024
_MAX_SWEEPS = 12
_EPS = 2.220446049250313e-16


@njit(cache=True)
def cosine_sigmoid_scalar(x, a, b):
    """Def. 15 with the GUIDE's a = b rule: weight 1 iff x <= a, then cosine to 0 at b."""
    if x <= a:
        return 1.0
    if x >= b:
        return 0.0
    return 0.5 * math.cos(math.pi * (x - a) / (b - a)) + 0.5


@njit(cache=True)
def eig3_jacobi(a, v, lam, vec):
    """Accurate eigen-decomposition of the symmetric 3x3 ``a`` (overwritten).

    Cyclic Jacobi with a relative stopping rule. ``lam`` (3,) receives the
    eigenvalues in descending order, ``vec`` (3, 3) the matching unit eigenvectors
    as columns; ``v`` is (3, 3) scratch.
    """
    for r in range(3):
        for c in range(3):
            v[r, c] = 1.0 if r == c else 0.0
    for _ in range(_MAX_SWEEPS):
        changed = _rotate(a, v, 0, 1)
        changed = _rotate(a, v, 0, 2) or changed
        changed = _rotate(a, v, 1, 2) or changed
        if not changed:
            break
    d0 = a[0, 0]
    d1 = a[1, 1]
    d2 = a[2, 2]
    # sort descending (stable on ties: lower column first)
    i0, i1, i2 = 0, 1, 2
    if d1 > d0:
        i0, i1 = 1, 0
    dd = (d0, d1, d2)
    if d2 > dd[i1]:
        if d2 > dd[i0]:
            i0, i1, i2 = 2, i0, i1
        else:
            i1, i2 = 2, i1
    order = (i0, i1, i2)
    for r in range(3):
        lam[r] = dd[order[r]]
        for m in range(3):
            vec[m, r] = v[m, order[r]]


@njit(parallel=True, cache=True)
def eigvals_batch_kernel(mats, out):
    """Eigenvalues (descending, not clipped) of symmetric (N, 3, 3) ``mats`` into (N, 3)."""
    n = mats.shape[0]
    nblocks = (n + _BLOCK - 1) // _BLOCK
    for blk in prange(nblocks):
        a = np.empty((3, 3))
        v = np.empty((3, 3))
        lam = np.empty(3)
        vec = np.empty((3, 3))
        for i in range(blk * _BLOCK, min(n, (blk + 1) * _BLOCK)):
            ok = True
            for r in range(3):
                for c in range(3):
                    a[r, c] = 0.5 * (mats[i, r, c] + mats[i, c, r])
                    if not math.isfinite(a[r, c]):
                        ok = False
            if not ok:
                out[i, 0] = np.nan
                out[i, 1] = np.nan
                out[i, 2] = np.nan
                continue
            eig3_jacobi(a, v, lam, vec)
            out[i, 0] = lam[0]
            out[i, 1] = lam[1]
            out[i, 2] = lam[2]


@njit(parallel=True, cache=True)
def angles_kernel(normals, idx, order, out):
    """Angle between each point's normal and its neighbours' (atan2 form, accurate at 0).

    Rows are visited in ``order`` (a permutation; see `spatial_order_kernel`).
    """
    n, kk = idx.shape
    for t in prange(n):
        i = order[t]
        nx = normals[i, 0]
        ny = normals[i, 1]
        nz = normals[i, 2]
        for j in range(kk):
            m = idx[i, j]
            dx = nx - normals[m, 0]
            dy = ny - normals[m, 1]
            dz = nz - normals[m, 2]
            sx = nx + normals[m, 0]
            sy = ny + normals[m, 1]
            sz = nz + normals[m, 2]
            x = 2.0 * math.atan2(
                math.sqrt(dx * dx + dy * dy + dz * dz), math.sqrt(sx * sx + sy * sy + sz * sz)
            )
            if x < ANGLE_ZERO:
                x = 0.0
            out[i, j] = x


@njit(cache=True)
def _same(ys, j, m):
    return ys[j, 0] == ys[m, 0] and ys[j, 1] == ys[m, 1] and ys[j, 2] == ys[m, 2]


@njit(cache=True)
def _gather(points, idx, i, kk, ys):
    """Fill ys[:kk] with neighbour coordinates relative to point i; False if non-finite."""
    px = points[i, 0]
    py = points[i, 1]
    pz = points[i, 2]
    ok = math.isfinite(px) and math.isfinite(py) and math.isfinite(pz)
    for j in range(kk):
        m = idx[i, j]
        ys[j, 0] = points[m, 0] - px
        ys[j, 1] = points[m, 1] - py
        ys[j, 2] = points[m, 2] - pz
        if not (math.isfinite(ys[j, 0]) and math.isfinite(ys[j, 1]) and math.isfinite(ys[j, 2])):
            ok = False
    return ok


@njit(cache=True)
def _weighted_cov(ys, ws, kk, a):
    """Eq. 5.4 into ``a`` (3, 3): weighted outer products about the unweighted mean.

    Returns a reason code (0 ok, 2 all weights zero, 3 < 3 distinct weighted points).
    """
    mx = 0.0
    my = 0.0
    mz = 0.0
    for j in range(kk):
        mx += ys[j, 0]
        my += ys[j, 1]
        mz += ys[j, 2]
    mx /= kk
    my /= kk
    mz /= kk
    c00 = 0.0
    c01 = 0.0
    c02 = 0.0
    c11 = 0.0
    c12 = 0.0
    c22 = 0.0
    wsum = 0.0
    n_distinct = 0
    first = -1
    second = -1
    for j in range(kk):
        w = ws[j]
        if w <= 0.0:
            continue
        wsum += w
        if n_distinct == 0:
            first = j
            n_distinct = 1
        elif n_distinct == 1:
            if not _same(ys, j, first):
                second = j
                n_distinct = 2
        elif n_distinct == 2:
            if not _same(ys, j, first) and not _same(ys, j, second):
                n_distinct = 3
        dx = ys[j, 0] - mx
        dy = ys[j, 1] - my
        dz = ys[j, 2] - mz
        c00 += w * dx * dx
        c01 += w * dx * dy
        c02 += w * dx * dz
        c11 += w * dy * dy
        c12 += w * dy * dz
        c22 += w * dz * dz
    a[0, 0] = c00
    a[0, 1] = c01
    a[0, 2] = c02
    a[1, 0] = c01
    a[1, 1] = c11
    a[1, 2] = c12
    a[2, 0] = c02
    a[2, 1] = c12
    a[2, 2] = c22
    if wsum <= 0.0:
        return REASON_ZERO_WEIGHTS
    if n_distinct < 3:
        return REASON_FEW_DISTINCT
    return REASON_OK


@njit(parallel=True, cache=True)
def covariance_kernel(points, idx, weights, use_weights, out, reason):
    """Eq. 5.4 covariances (N, 3, 3) of the full rows of ``idx`` with optional weights."""
    n, kk = idx.shape
    nblocks = (n + _BLOCK - 1) // _BLOCK
    for blk in prange(nblocks):
        ys = np.empty((kk, 3))
        ws = np.ones(kk)
        a = np.empty((3, 3))
        for i in range(blk * _BLOCK, min(n, (blk + 1) * _BLOCK)):
            ok = _gather(points, idx, i, kk, ys)
            if use_weights:
                for j in range(kk):
                    ws[j] = weights[i, j]
                    if not math.isfinite(ws[j]):
                        ok = False
            if not ok:
                for r in range(3):
                    for c in range(3):
                        out[i, r, c] = np.nan
                reason[i] = REASON_NONFINITE
                continue
            reason[i] = _weighted_cov(ys, ws, kk, a)
            for r in range(3):
                for c in range(3):
                    out[i, r, c] = a[r, c]


@njit(cache=True)
def _xlogx(x):
    if x <= 0.0:
        return 0.0
    return x * math.log(x)


@njit(parallel=True, cache=True)
def features_kernel(eig, vec3, reason, m1, m2, out):
    """Per-point features from eigenvalues into ``out`` (N, 11); NaN where reason != 0.

    Columns: linearity, planarity, scattering, E_dim, omnivariance, anisotropy
    (reversed, 6.2), change of curvature, eigenentropy, eigenvalue sum, verticality,
    flatness (6.1).
    """
    n = eig.shape[0]
    for i in prange(n):
        if reason[i] != REASON_OK:
            for c in range(N_FEATURES):
                out[i, c] = np.nan
            continue
        l1 = eig[i, 0]
        l2 = eig[i, 1]
        l3 = eig[i, 2]
        s = l1 + l2 + l3
        lin = (l1 - l2) / l1
        pla = (l2 - l3) / l1
        sca = l3 / l1
        e1 = l1 / s
        e2 = l2 / s
        e3 = l3 / s
        out[i, 0] = lin
        out[i, 1] = pla
        out[i, 2] = sca
        out[i, 3] = 0.0 - (_xlogx(lin) + _xlogx(pla) + _xlogx(sca))
        out[i, 4] = (e1 * e2 * e3) ** (1.0 / 3.0)
        out[i, 5] = 1.0 - (e1 - e3) / e1
        out[i, 6] = e3 / (e1 + e2 + e3)
        out[i, 7] = 0.0 - (_xlogx(e1) + _xlogx(e2) + _xlogx(e3))
        out[i, 8] = s
        out[i, 9] = 1.0 - abs(vec3[i, 2])
        out[i, 10] = (1.0 - l2 / l1) ** m1 + 1.0 - (1.0 - l3 / l1) ** m2


@njit(cache=True)
def _criterion(l1, l2, l3, criterion):
    """0: E_dim (Eq. 5.7) from L, P, S; 1: eigenentropy of the normalised eigenvalues."""
    if criterion == 0:
        lin = (l1 - l2) / l1
        pla = (l2 - l3) / l1
        sca = l3 / l1
        return -(_xlogx(lin) + _xlogx(pla) + _xlogx(sca))
    s = l1 + l2 + l3
    return -(_xlogx(l1 / s) + _xlogx(l2 / s) + _xlogx(l3 / s))


@njit(cache=True, inline="always")
def _cos_third(v):
    """cos(acos(v^2 - 1) / 3) for v in [0, sqrt 2] without trigonometric calls.

    Writing c = 1/2 + v h, the root c in [1/2, 1] of 4c^3 - 3c = v^2 - 1 solves
    2 h^2 (3 + 2 v h) = 1 with h in [0.353, 0.409]; a cubic fit (error < 7e-5)
    and two Newton steps (derivative 12 h (1 + v h) >= 4.2) give h to rounding.
    """
    h = ((-0.0028269 * v + 0.01523889) * v - 0.05456088) * v + 0.40818365
    for _ in range(2):
        vh = v * h
        h -= (2.0 * h * h * (3.0 + 2.0 * vh) - 1.0) / (12.0 * h * (1.0 + vh))
    return 0.5 + v * h


@njit(cache=True)
def eig3_fast(c00, c01, c02, c11, c12, c22):
    """Eigenvalues (descending, clipped at 0) of a symmetric PSD 3x3, no trig calls.

    The trace-shifted, scaled trigonometric closed form (B = (C - qI)/p,
    r = det(B)/2 clamped to [-1, 1]), with cos(acos(r)/3) and cos(acos(r)/3 + 2pi/3)
    from `_cos_third` of sqrt(1 + r) and sqrt(1 - r) (the smallest root is minus the
    largest root for -r): about 1.5x faster than acos + 2 cos and as accurate
    (double roots resolved to ~1e-8 lambda_1; `eigh3_accurate` refines).
    """
    q = (c00 + c11 + c22) / 3.0
    b00 = c00 - q
    b11 = c11 - q
    b22 = c22 - q
    p2 = b00 * b00 + b11 * b11 + b22 * b22 + 2.0 * (c01 * c01 + c02 * c02 + c12 * c12)
    if p2 <= 0.0:
        v = max(q, 0.0)
        return v, v, v
    p = math.sqrt(p2 / 6.0)
    inv = 1.0 / p
    d00 = b00 * inv
    d11 = b11 * inv
    d22 = b22 * inv
    d01 = c01 * inv
    d02 = c02 * inv
    d12 = c12 * inv
    det = (
        d00 * (d11 * d22 - d12 * d12)
        - d01 * (d01 * d22 - d12 * d02)
        + d02 * (d01 * d12 - d11 * d02)
    )
    r = min(max(0.5 * det, -1.0), 1.0)
    l1 = q + 2.0 * p * _cos_third(math.sqrt(1.0 + r))
    l3 = q - 2.0 * p * _cos_third(math.sqrt(1.0 - r))
    l2 = 3.0 * q - l1 - l3
    if l2 > l1:
        l2 = l1
    if l2 < l3:
        l2 = l3
    return max(l1, 0.0), max(l2, 0.0), max(l3, 0.0)


@njit(cache=True, inline="always")
def _entropy_term_bound(t, log_t, inv_t, delta):
    """Lower bound of -s ln s over s in [t - delta, t + delta] (0 when delta >= t / 2).

    -s ln s is >= 0 on [0, 1]; for delta < t / 2 its slope |ln s + 1| there is at
    most |ln t| + 1 + 2 delta / t in magnitude (``inv_t`` = 1 / t).
    """
    if not delta < 0.5 * t:
        return 0.0
    return -t * log_t - delta * (abs(log_t) + 1.0 + 2.0 * delta * inv_t)


#: absolute margin (in E_dim units) a pruning bound must clear
_PRUNE_MARGIN = 1e-9
#: allowance for the closed-form eigenvalue error of a reference, relative to lambda_1
_EIG_SLACK = 1e-7


@njit(parallel=True, cache=True)
def search_kernel(
    points,
    idx,
    order,
    kmin,
    kmax,
    ang,
    use_normals,
    pair_a,
    pair_b,
    criterion,
    best_val,
    best_k,
    best_pair,
    reason,
):
    """Optimal (a, b, k) per point (Eq. 5.9) by running moment sums over k.

    Per point the weights of the kmax sorted neighbours are computed once for each
    (a, b) pair (given in lexicographic order); pairs whose weights are all 0/1 and
    select the same neighbours as an earlier pair are dropped (identical values; the
    earlier pair wins the tie). k then grows by one neighbour at a time while the
    weighted moments (sum w, sum w y, sum w y y^T about the point itself) of all
    remaining pairs and the unweighted sum of y are updated, so each covariance
    costs O(1). At each k the first valid pair is solved exactly; for the next
    pairs a certified lower bound of E_dim from the last solved covariance (Weyl:
    eigenvalues move by at most the Frobenius norm of the difference; slope bound
    of -t ln t) skips the solve when it cannot beat the best value so far
    (criterion E_dim); with the eigenentropy criterion the collision-entropy bound
    is used instead. Ties: smallest k, then a, then b. Without normals there is
    one pair with all weights 1. Points are visited in ``order``.
    """
    n = idx.shape[0]
    n_pairs = pair_a.shape[0] if use_normals else 1
    dedupe = use_normals and kmax <= 64
    nblocks = (n + _BLOCK - 1) // _BLOCK
    for blk in prange(nblocks):
        ys = np.empty((kmax, 3))
        ws = np.ones((n_pairs, kmax))
        act = np.empty(n_pairs, dtype=np.int64)
        mom = np.empty((10, n_pairs))
        wa = np.empty((kmax, n_pairs))
        dist = np.empty((n_pairs, 3), dtype=np.int64)
        masks = np.empty(n_pairs, dtype=np.uint64)
        rho = np.empty((n_pairs, kmax))
        for t in range(blk * _BLOCK, min(n, (blk + 1) * _BLOCK)):
            i = order[t]
            best_val[i] = np.inf
            best_k[i] = -1
            best_pair[i] = -1
            ok = _gather(points, idx, i, kmax, ys)
            if use_normals:
                for j in range(kmax):
                    if not math.isfinite(ang[i, j]):
                        ok = False
            if not ok:
                reason[i] = REASON_NONFINITE
                continue
            n_act = 0
            n_masks = 0
            x_max = 0.0
            if use_normals:
                for j in range(kmax):
                    x_max = max(x_max, ang[i, j])
            for pr in range(n_pairs):
                if use_normals:
                    a = pair_a[pr]
                    b = pair_b[pr]
                    binary = True
                    mask = np.uint64(0)
                    if dedupe and a >= x_max:
                        # all weights 1: the full mask; skip the loop if seen
                        mask = ~np.uint64(0) >> np.uint64(64 - kmax)
                        seen = False
                        for m in range(n_masks):
                            if masks[m] == mask:
                                seen = True
                                break
                        if seen:
                            continue
                        mask = np.uint64(0)
                    for j in range(kmax):
                        x = ang[i, j]
                        if x <= a:
                            w = 1.0
                            if j < 64:
                                mask |= np.uint64(1) << np.uint64(j)
                        elif x >= b:
                            w = 0.0
                        else:
                            w = 0.5 * math.cos(math.pi * (x - a) / (b - a)) + 0.5
                            binary = False
                        ws[pr, j] = w
                    if dedupe and binary:
                        seen = False
                        for m in range(n_masks):
                            if masks[m] == mask:
                                seen = True
                                break
                        if seen:
                            continue
                        masks[n_masks] = mask
                        n_masks += 1
                act[n_act] = pr
                n_act += 1
            # rho[s, j]: max over neighbours <= j of the weight ratio of pair s to the
            # previous active pair (>= 1; inf when exactly one of them is zero)
            for s in range(1, n_act):
                p0 = act[s - 1]
                p1 = act[s]
                run = 1.0
                for j in range(kmax):
                    w0 = ws[p0, j]
                    w1 = ws[p1, j]
                    if w0 > 0.0 and w1 > 0.0:
                        run = max(run, max(w0, w1) / min(w0, w1))
                    elif w0 > 0.0 or w1 > 0.0:
                        run = np.inf
                    rho[s, j] = run
            for s in range(n_act):
                dist[s, 0] = 0
                dist[s, 1] = -1
                dist[s, 2] = -1
                for c in range(10):
                    mom[c, s] = 0.0
                for j in range(kmax):
                    wa[j, s] = ws[act[s], j]
            code = REASON_FEW_DISTINCT
            bv = np.inf
            bk = -1
            bp = -1
            ux = 0.0
            uy = 0.0
            uz = 0.0
            for j in range(kmax):
                yx = ys[j, 0]
                yy = ys[j, 1]
                yz = ys[j, 2]
                ux += yx
                uy += yy
                uz += yz
                # zero weights add exact zeros: branch-free, vectorisable over pairs
                for s in range(n_act):
                    w = wa[j, s]
                    mom[0, s] += w
                    mom[1, s] += w * yx
                    mom[2, s] += w * yy
                    mom[3, s] += w * yz
                    mom[4, s] += w * yx * yx
                    mom[5, s] += w * yx * yy
                    mom[6, s] += w * yx * yz
                    mom[7, s] += w * yy * yy
                    mom[8, s] += w * yy * yz
                    mom[9, s] += w * yz * yz
                for s in range(n_act):
                    if dist[s, 0] < 3 and wa[j, s] > 0.0:
                        nd = dist[s, 0]
                        if nd == 0:
                            dist[s, 1] = j
                            dist[s, 0] = 1
                        elif nd == 1:
                            if not _same(ys, j, dist[s, 1]):
                                dist[s, 2] = j
                                dist[s, 0] = 2
                        elif nd == 2:
                            if not _same(ys, j, dist[s, 1]) and not _same(ys, j, dist[s, 2]):
                                dist[s, 0] = 3
                k = j + 1
                if k < kmin:
                    continue
                mx = ux / k
                my = uy / k
                mz = uz / k
                have_ref = False
                chain = 1.0
                r00 = r01 = r02 = r11 = r12 = r22 = 0.0
                rl1 = rlin = rpla = rsca = lnl = lnp = lns = rval = 0.0
                inl = inp = ins = 0.0
                for s in range(n_act):
                    if have_ref:
                        chain *= rho[s, j]
                    if dist[s, 0] < 3:
                        continue
                    pr = act[s]
                    sw = mom[0, s]
                    sx = mom[1, s]
                    sy = mom[2, s]
                    sz = mom[3, s]
                    # C = Syy - Sy m^T - m Sy^T + W m m^T, m = unweighted mean of y
                    c00 = mom[4, s] - 2.0 * sx * mx + sw * mx * mx
                    c11 = mom[7, s] - 2.0 * sy * my + sw * my * my
                    c22 = mom[9, s] - 2.0 * sz * mz + sw * mz * mz
                    c01 = mom[5, s] - sx * my - mx * sy + sw * mx * my
                    c02 = mom[6, s] - sx * mz - mx * sz + sw * mx * mz
                    c12 = mom[8, s] - sy * mz - my * sz + sw * my * mz
                    if criterion == 1:
                        if bk >= 0:
                            # Shannon entropy >= collision entropy -ln(|C|_F^2 / tr^2)
                            tr = c00 + c11 + c22
                            fro = (
                                c00 * c00
                                + c11 * c11
                                + c22 * c22
                                + 2.0 * (c01 * c01 + c02 * c02 + c12 * c12)
                            )
                            if tr > 0.0 and fro > 0.0 and -math.log(fro / (tr * tr)) - 1e-12 >= bv:
                                continue
                    elif have_ref and rval > bv + _PRUNE_MARGIN:
                        # (the bound never exceeds the reference's own value)
                        g = chain * chain - 1.0
                        if g < 0.25:
                            # weights within a factor F of the reference's (same
                            # unweighted barycentre): C / F <= C' <= F C, each lambda_i
                            # within that factor, so x = l2 / l1 and y = l3 / l1 by F^2
                            xr = 1.0 - rlin
                            d_l = xr * g + 2.0 * _EIG_SLACK
                            d_p = (xr + rsca) * g + 4.0 * _EIG_SLACK
                            d_s = rsca * g + 2.0 * _EIG_SLACK
                            lb = (
                                _entropy_term_bound(rlin, lnl, inl, d_l)
                                + _entropy_term_bound(rpla, lnp, inp, d_p)
                                + _entropy_term_bound(rsca, lns, ins, d_s)
                            )
                            if lb > bv + _PRUNE_MARGIN:
                                continue
                        else:
                            e00 = c00 - r00
                            e11 = c11 - r11
                            e22 = c22 - r22
                            e01 = c01 - r01
                            e02 = c02 - r02
                            e12 = c12 - r12
                            eps = math.sqrt(
                                e00 * e00
                                + e11 * e11
                                + e22 * e22
                                + 2.0 * (e01 * e01 + e02 * e02 + e12 * e12)
                            )
                            eps += _EIG_SLACK * rl1
                            # Weyl: |d lambda_i| <= eps, so L, S move by <= dw and P by 2 dw
                            dw = 2.0 * eps / (rl1 - eps) if eps < 0.5 * rl1 else np.inf
                            lb = (
                                _entropy_term_bound(rlin, lnl, inl, dw)
                                + _entropy_term_bound(rpla, lnp, inp, 2.0 * dw)
                                + _entropy_term_bound(rsca, lns, ins, dw)
                            )
                            if lb > bv + _PRUNE_MARGIN:
                                continue
                    l1, l2, l3 = eig3_fast(c00, c01, c02, c11, c12, c22)
                    if not l1 > 0.0:
                        if code == REASON_FEW_DISTINCT:
                            code = REASON_ZERO_EIGENSUM
                        continue
                    if criterion == 1:
                        sm = l1 + l2 + l3
                        val = -(_xlogx(l1 / sm) + _xlogx(l2 / sm) + _xlogx(l3 / sm))
                    else:
                        lin = (l1 - l2) / l1
                        pla = (l2 - l3) / l1
                        sca = l3 / l1
                        lnl = math.log(lin) if lin > 0.0 else 0.0
                        lnp = math.log(pla) if pla > 0.0 else 0.0
                        lns = math.log(sca) if sca > 0.0 else 0.0
                        val = -(lin * lnl + pla * lnp + sca * lns)
                        have_ref = True
                        r00, r01, r02, r11, r12, r22 = c00, c01, c02, c11, c12, c22
                        rl1, rlin, rpla, rsca, rval = l1, lin, pla, sca, val
                        inl = 1.0 / lin if lin > 0.0 else 0.0
                        inp = 1.0 / pla if pla > 0.0 else 0.0
                        ins = 1.0 / sca if sca > 0.0 else 0.0
                        chain = 1.0
                    if val < bv or (val == bv and (k < bk or (k == bk and pr < bp))):
                        bv = val
                        bk = k
                        bp = pr
            best_val[i] = bv
            best_k[i] = bk
            best_pair[i] = bp
            reason[i] = REASON_OK if bk >= 0 else code


@njit(cache=True)
def _null_vector(c00, c01, c02, c11, c12, c22, lam):
    """Unit vector spanning the kernel of C - lam I (largest cross product of two rows)."""
    a00 = c00 - lam
    a11 = c11 - lam
    a22 = c22 - lam
    # rows r0 = (a00, c01, c02), r1 = (c01, a11, c12), r2 = (c02, c12, a22)
    x0 = c01 * c12 - c02 * a11
    y0 = c02 * c01 - a00 * c12
    z0 = a00 * a11 - c01 * c01
    x1 = c01 * a22 - c02 * c12
    y1 = c02 * c02 - a00 * a22
    z1 = a00 * c12 - c01 * c02
    x2 = a11 * a22 - c12 * c12
    y2 = c12 * c02 - c01 * a22
    z2 = c01 * c12 - a11 * c02
    n0 = x0 * x0 + y0 * y0 + z0 * z0
    n1 = x1 * x1 + y1 * y1 + z1 * z1
    n2 = x2 * x2 + y2 * y2 + z2 * z2
    if n0 >= n1 and n0 >= n2:
        x, y, z, nn = x0, y0, z0, n0
    elif n1 >= n2:
        x, y, z, nn = x1, y1, z1, n1
    else:
        x, y, z, nn = x2, y2, z2, n2
    if not nn > 0.0:
        return 0.0, 0.0, 0.0, False
    s = 1.0 / math.sqrt(nn)
    return x * s, y * s, z * s, True


@njit(cache=True)
def eigh3_accurate(c00, c01, c02, c11, c12, c22):
    """Eigenvalues (descending, >= 0) and the eigenvectors of lambda_1 and lambda_3.

    Closed-form estimate, then deflation: the eigenvector of the eigenvalue farthest
    from the other two is computed from a cross product (well conditioned), its
    eigenvalue as a Rayleigh quotient, and the remaining pair from the 2x2 matrix
    in the orthogonal plane with the stable hypot formula. Absolute errors are a
    few ulps of lambda_1 even for (near) double eigenvalues.
    """
    l1t, l2t, l3t = eig3_fast(c00, c01, c02, c11, c12, c22)
    top = (l1t - l2t) >= (l2t - l3t)
    lam = l1t if top else l3t
    vx, vy, vz, ok = _null_vector(c00, c01, c02, c11, c12, c22, lam)
    if not ok:  # C = lam I
        q = (c00 + c11 + c22) / 3.0
        q = max(q, 0.0)
        return q, q, q, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0
    # a unit vector u1 orthogonal to v (cross with the axis least aligned with v)
    ax = abs(vx)
    ay = abs(vy)
    az = abs(vz)
    if ax <= ay and ax <= az:
        ux, uy, uz = 0.0, vz, -vy
    elif ay <= az:
        ux, uy, uz = -vz, 0.0, vx
    else:
        ux, uy, uz = vy, -vx, 0.0
    s = 1.0 / math.sqrt(ux * ux + uy * uy + uz * uz)
    ux *= s
    uy *= s
    uz *= s
    wx = vy * uz - vz * uy
    wy = vz * ux - vx * uz
    wz = vx * uy - vy * ux
    # C v, C u, C w
    cvx = c00 * vx + c01 * vy + c02 * vz
    cvy = c01 * vx + c11 * vy + c12 * vz
    cvz = c02 * vx + c12 * vy + c22 * vz
    cux = c00 * ux + c01 * uy + c02 * uz
    cuy = c01 * ux + c11 * uy + c12 * uz
    cuz = c02 * ux + c12 * uy + c22 * uz
    cwx = c00 * wx + c01 * wy + c02 * wz
    cwy = c01 * wx + c11 * wy + c12 * wz
    cwz = c02 * wx + c12 * wy + c22 * wz
    ls = vx * cvx + vy * cvy + vz * cvz
    a = ux * cux + uy * cuy + uz * cuz
    b = ux * cwx + uy * cwy + uz * cwz
    c = wx * cwx + wy * cwy + wz * cwz
    mid = 0.5 * (a + c)
    hd = 0.5 * (a - c)
    h = math.sqrt(hd * hd + b * b)
    lp = mid + h
    lm = mid - h
    # eigenvector of the 2x2 block: (b, l - a) or (l - c, b), the longer one
    if top:
        lt = lm
    else:
        lt = lp
    p0 = b
    p1 = lt - a
    q0 = lt - c
    q1 = b
    if p0 * p0 + p1 * p1 >= q0 * q0 + q1 * q1:
        t0, t1 = p0, p1
    else:
        t0, t1 = q0, q1
    tn = t0 * t0 + t1 * t1
    if tn > 0.0:
        tn = 1.0 / math.sqrt(tn)
        t0 *= tn
        t1 *= tn
    elif top:  # equal pair: any vector of the plane
        t0, t1 = 0.0, 1.0
    else:
        t0, t1 = 1.0, 0.0
    ex = t0 * ux + t1 * wx
    ey = t0 * uy + t1 * wy
    ez = t0 * uz + t1 * wz
    if top:
        l1, l2, l3 = ls, lp, lm
        e1x, e1y, e1z = vx, vy, vz
        e3x, e3y, e3z = ex, ey, ez
    else:
        l1, l2, l3 = lp, lm, ls
        e1x, e1y, e1z = ex, ey, ez
        e3x, e3y, e3z = vx, vy, vz
    # rounding can break the order only between nearly equal values
    if l2 > l1:
        l2 = l1
    if l3 > l2:
        l3 = l2
    return max(l1, 0.0), max(l2, 0.0), max(l3, 0.0), e1x, e1y, e1z, e3x, e3y, e3z


@njit(cache=True)
def _pow_int(x, m):
    r = 1.0
    for _ in range(m):
        r *= x
    return r


@njit(parallel=True, cache=True)
def fused_kernel(
    points, idx, order, k_of, ang, use_normals, a_of, b_of, m1, m2, eig, vec1, vec3, feats, reason
):
    """One (a, b, k) choice per point: covariance, eigen-decomposition and features.

    Single pass over the neighbours accumulating the moments about the point itself
    (sum w, sum w y, sum w y y^T) and the unweighted sum of y; Eq. 5.4 follows
    from them. Eigenvalues and vectors by `eigh3_accurate`; features as in
    `features_kernel` (columns of `N_FEATURES`). Degenerate rows are NaN. Points
    are visited in ``order`` (see `spatial_order_kernel`).
    """
    n = idx.shape[0]
    for t in prange(n):
        i = order[t]
        kk = k_of[i]
        px = points[i, 0]
        py = points[i, 1]
        pz = points[i, 2]
        finite = math.isfinite(px) and math.isfinite(py) and math.isfinite(pz)
        ux = 0.0
        uy = 0.0
        uz = 0.0
        sw = 0.0
        sx = 0.0
        sy = 0.0
        sz = 0.0
        sxx = 0.0
        sxy = 0.0
        sxz = 0.0
        syy = 0.0
        syz = 0.0
        szz = 0.0
        n_distinct = 0
        first = -1
        second = -1
        a = a_of[i]
        b = b_of[i]
        for j in range(kk):
            m = idx[i, j]
            yx = points[m, 0] - px
            yy = points[m, 1] - py
            yz = points[m, 2] - pz
            ux += yx
            uy += yy
            uz += yz
            w = 1.0
            if use_normals:
                x = ang[i, j]
                if not math.isfinite(x):
                    finite = False
                w = cosine_sigmoid_scalar(x, a, b)
            if w > 0.0:
                sw += w
                sx += w * yx
                sy += w * yy
                sz += w * yz
                sxx += w * yx * yx
                sxy += w * yx * yy
                sxz += w * yx * yz
                syy += w * yy * yy
                syz += w * yy * yz
                szz += w * yz * yz
                if n_distinct < 3:
                    if n_distinct == 0:
                        first = m
                        n_distinct = 1
                    elif not (
                        points[m, 0] == points[first, 0]
                        and points[m, 1] == points[first, 1]
                        and points[m, 2] == points[first, 2]
                    ):
                        if n_distinct == 1:
                            second = m
                            n_distinct = 2
                        elif not (
                            points[m, 0] == points[second, 0]
                            and points[m, 1] == points[second, 1]
                            and points[m, 2] == points[second, 2]
                        ):
                            n_distinct = 3
        code = REASON_OK
        if not (finite and math.isfinite(ux + uy + uz)):
            code = REASON_NONFINITE
        elif sw <= 0.0:
            code = REASON_ZERO_WEIGHTS
        elif n_distinct < 3:
            code = REASON_FEW_DISTINCT
        l1 = 0.0
        l2 = 0.0
        l3 = 0.0
        if code == REASON_OK:
            mx = ux / kk
            my = uy / kk
            mz = uz / kk
            c00 = sxx - 2.0 * sx * mx + sw * mx * mx
            c11 = syy - 2.0 * sy * my + sw * my * my
            c22 = szz - 2.0 * sz * mz + sw * mz * mz
            c01 = sxy - sx * my - mx * sy + sw * mx * my
            c02 = sxz - sx * mz - mx * sz + sw * mx * mz
            c12 = syz - sy * mz - my * sz + sw * my * mz
            l1, l2, l3, e1x, e1y, e1z, e3x, e3y, e3z = eigh3_accurate(c00, c01, c02, c11, c12, c22)
            if not l1 > 0.0:
                code = REASON_ZERO_EIGENSUM
        reason[i] = code
        if code != REASON_OK:
            for r in range(3):
                eig[i, r] = np.nan
                vec1[i, r] = np.nan
                vec3[i, r] = np.nan
            for c in range(N_FEATURES):
                feats[i, c] = np.nan
            continue
        eig[i, 0] = l1
        eig[i, 1] = l2
        eig[i, 2] = l3
        vec1[i, 0] = e1x
        vec1[i, 1] = e1y
        vec1[i, 2] = e1z
        vec3[i, 0] = e3x
        vec3[i, 1] = e3y
        vec3[i, 2] = e3z
        s = l1 + l2 + l3
        lin = (l1 - l2) / l1
        pla = (l2 - l3) / l1
        sca = l3 / l1
        e1 = l1 / s
        e2 = l2 / s
        e3 = l3 / s
        feats[i, 0] = lin
        feats[i, 1] = pla
        feats[i, 2] = sca
        feats[i, 3] = 0.0 - (_xlogx(lin) + _xlogx(pla) + _xlogx(sca))
        feats[i, 4] = np.cbrt(e1 * e2 * e3)
        feats[i, 5] = 1.0 - (e1 - e3) / e1
        feats[i, 6] = e3 / (e1 + e2 + e3)
        feats[i, 7] = 0.0 - (_xlogx(e1) + _xlogx(e2) + _xlogx(e3))
        feats[i, 8] = s
        feats[i, 9] = 1.0 - abs(e3z)
        feats[i, 10] = _pow_int(1.0 - l2 / l1, m1) + 1.0 - _pow_int(1.0 - l3 / l1, m2)


@njit(cache=True)
def spatial_order_kernel(points, bits):
    """A cache-friendly processing order: points bucketed by Morton-ordered grid cells.

    Counting sort on a 2^bits per axis grid over the bounding box (O(N)); points
    processed in this order reuse their neighbours' coordinates from cache, which
    matters when the input order is spatially random. Non-finite points go last.
    """
    n = points.shape[0]
    lo = np.full(3, np.inf)
    hi = np.full(3, -np.inf)
    for i in range(n):
        ok = True
        for d in range(3):
            if not math.isfinite(points[i, d]):
                ok = False
        if ok:
            for d in range(3):
                lo[d] = min(lo[d], points[i, d])
                hi[d] = max(hi[d], points[i, d])
    side = 1 << bits
    n_cells = 1 << (3 * bits)
    scale = np.empty(3)
    for d in range(3):
        ext = hi[d] - lo[d]
        scale[d] = side / ext if ext > 0 else 0.0
    key = np.empty(n, dtype=np.int64)
    for i in range(n):
        code = 0
        ok = True
        q = np.empty(3, dtype=np.int64)
        for d in range(3):
            v = points[i, d]
            if not math.isfinite(v):
                ok = False
                break
            c = int((v - lo[d]) * scale[d])
            q[d] = min(max(c, 0), side - 1)
        if ok:
            for bit in range(bits):
                for d in range(3):
                    code |= ((q[d] >> bit) & 1) << (3 * bit + d)
            key[i] = code
        else:
            key[i] = n_cells
    counts = np.zeros(n_cells + 2, dtype=np.int64)
    for i in range(n):
        counts[key[i] + 1] += 1
    for c in range(1, n_cells + 2):
        counts[c] += counts[c - 1]
    order = np.empty(n, dtype=np.int64)
    for i in range(n):
        order[counts[key[i]]] = i
        counts[key[i]] += 1
    return order
