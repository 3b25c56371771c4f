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

from .._core._prefetch import prefetch_read, prefetch_write
from .._core.tolerances import ANGLE_ZERO
from ..normals._kernels import _rotate  # the same Jacobi rotation as the normals room

__all__ = [
    "N_FEATURES",
    "N_OUT",
    "angles_kernel",
    "covariance_kernel",
    "eig3_fast",
    "eig3_jacobi",
    "eigh3_accurate",
    "eigvals_batch_kernel",
    "features_kernel",
    "fused_kernel",
    "index_range_kernel",
    "optimal_kernel",
    "unit_normals_kernel",
]

REASON_OK = 0
REASON_NONFINITE = 1
REASON_ZERO_WEIGHTS = 2
REASON_FEW_DISTINCT = 3
REASON_ZERO_EIGENSUM = 4
#: internal: a neighbour index out of range (the caller raises)
REASON_BAD_INDEX = 255

#: columns of the feature matrix written by `features_kernel`
N_FEATURES = 11
#: points per parallel block (scratch arrays are allocated once per block)
_BLOCK = 1024
_MAX_SWEEPS = 12
_EPS = 2.220446049250313e-16
#: how many points ahead (in visiting order) the kernels prefetch rows
_AHEAD = 8


@njit(cache=True, error_model="numpy")
def cosine_sigmoid_scalar(x, a, b):
    """Def. 15 with the GUIDE's a = b rule: weight 1 iff x <= a, then cosine to 0 at b.

    The ramp 0.5 cos(pi u) + 0.5 is `_sigmoid_ramp` (a polynomial, error < 3e-16) of
    u = (x - a) * (1 / (b - a)), the form `optimal_kernel` uses for its weights (so
    both give the same weights bit for bit).
    """
    if x <= a:
        return 1.0
    if x >= b:
        return 0.0
    return _sigmoid_ramp((x - a) * (1.0 / (b - a)))


#: odd Taylor coefficients of sin(pi t), |t| <= 1/2 (truncation error < 3e-16)
_SINPI = (
    3.141592653589793,
    -5.167712780049969,
    2.550164039877345,
    -0.5992645293207919,
    0.08214588661112819,
    -0.007370430945714348,
    0.00046630280576761234,
    -2.1915353447830204e-05,
    7.952054001475508e-07,
    -2.2948428997269856e-08,
    5.392664662608125e-10,
)


@njit(cache=True, inline="always", error_model="numpy")
def _sigmoid_ramp(u):
    """0.5 cos(pi u) + 0.5 for u in [0, 1] as a polynomial (absolute error < 3e-16).

    = 0.5 - 0.5 sin(pi t) with t = u - 1/2; about 4x cheaper than ``math.cos`` and
    vectorisable. Clamped at 0 so round-off never makes a weight negative.
    """
    t = u - 0.5
    t2 = t * t
    # Horner written out (as in `_atan2_nonneg`): a helper looping over the
    # coefficient tuple gave the same bits but made the search ~5 % slower
    p = _SINPI[10]
    p = p * t2 + _SINPI[9]
    p = p * t2 + _SINPI[8]
    p = p * t2 + _SINPI[7]
    p = p * t2 + _SINPI[6]
    p = p * t2 + _SINPI[5]
    p = p * t2 + _SINPI[4]
    p = p * t2 + _SINPI[3]
    p = p * t2 + _SINPI[2]
    p = p * t2 + _SINPI[1]
    p = p * t2 + _SINPI[0]
    return max(0.5 - 0.5 * (p * t), 0.0)


@njit(cache=True, error_model="numpy")
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


@njit(parallel=True, cache=True, error_model="numpy")
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


@njit(parallel=True, cache=True, error_model="numpy")
def angles_kernel(normals, idx, order, out):
    """Angle between each point's normal and its neighbours' (`_normal_angle`).

    Rows are visited in ``order`` (a permutation; see `pointatlas._core._sort.morton_order`) in
    blocks, the index and output rows `_AHEAD` points later prefetched.
    """
    n, kk = idx.shape
    nblocks = (n + _BLOCK - 1) // _BLOCK
    for blk in prange(nblocks):
        t_end = min(n, (blk + 1) * _BLOCK)
        for t in range(blk * _BLOCK, t_end):
            if t + _AHEAD < t_end:
                ia = order[t + _AHEAD]
                _prefetch_row(idx, ia)
                _prefetch_out(out, ia)
                prefetch_read(normals, ia, 0)
            i = order[t]
            nx = normals[i, 0]
            ny = normals[i, 1]
            nz = normals[i, 2]
            for j in range(kk):
                m = idx[i, j]
                out[i, j] = _normal_angle(nx, ny, nz, normals[m, 0], normals[m, 1], normals[m, 2])


@njit(parallel=True, cache=True, error_model="numpy")
def unit_normals_kernel(normals, out):
    """Rows of ``normals`` divided by their length; NaN where non-finite, shorter than
    1e-12 or so long that the squared length overflows (numpy's norm and division
    otherwise, bit for bit)."""
    for i in prange(normals.shape[0]):
        x = normals[i, 0]
        y = normals[i, 1]
        z = normals[i, 2]
        length = math.sqrt(x * x + y * y + z * z)
        ux = x / length
        uy = y / length
        uz = z / length
        good = (
            math.isfinite(ux)
            and math.isfinite(uy)
            and math.isfinite(uz)
            and 1e-12 <= length < np.inf
        )
        out[i, 0] = ux if good else np.nan
        out[i, 1] = uy if good else np.nan
        out[i, 2] = uz if good else np.nan


@njit(parallel=True, cache=True, error_model="numpy")
def index_range_kernel(idx):
    """(min, max) of an (N, k) int64 table, in parallel (one pass instead of two)."""
    n = idx.shape[0]
    nblocks = (n + _BLOCK - 1) // _BLOCK
    los = np.empty(nblocks, dtype=np.int64)
    his = np.empty(nblocks, dtype=np.int64)
    for blk in prange(nblocks):
        lo = idx[blk * _BLOCK, 0]
        hi = lo
        for t in range(blk * _BLOCK, min(n, (blk + 1) * _BLOCK)):
            for j in range(idx.shape[1]):
                v = idx[t, j]
                lo = min(lo, v)
                hi = max(hi, v)
        los[blk] = lo
        his[blk] = hi
    return los.min(), his.max()


@njit(cache=True, error_model="numpy")
def _same(ys, j, m):
    return ys[j, 0] == ys[m, 0] and ys[j, 1] == ys[m, 1] and ys[j, 2] == ys[m, 2]


@njit(cache=True, error_model="numpy")
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


@njit(cache=True, error_model="numpy")
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
        n_distinct, first, second = _count_distinct(ys, j, n_distinct, first, second)
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


@njit(parallel=True, cache=True, error_model="numpy")
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


@njit(cache=True, error_model="numpy")
def _xlogx(x):
    if x <= 0.0:
        return 0.0
    return x * math.log(x)


@njit(parallel=True, cache=True, error_model="numpy")
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


@njit(cache=True, error_model="numpy")
def _criterion(l1, l2, l3, criterion):
    """0: E_dim (Eq. 5.7) from L, P, S; 1: eigenentropy of the normalised eigenvalues."""
    if criterion == 0:
        lin = (l1 - l2) / l1
        pla = (l2 - l3) / l1
        sca = l3 / l1
        return -(_xlogx(lin) + _xlogx(pla) + _xlogx(sca))
    s = l1 + l2 + l3
    return -(_xlogx(l1 / s) + _xlogx(l2 / s) + _xlogx(l3 / s))


#: 1/3 and 1/6 (products instead of divisions in the closed form)
_THIRD = 1.0 / 3.0
_SIXTH = 1.0 / 6.0


@njit(cache=True, inline="always", error_model="numpy")
def _ct_start(v):
    """Cubic first guess of h(v), the root of 2 h^2 (3 + 2 v h) = 1, v in [0, sqrt 2].

    cos(acos(v^2 - 1) / 3) = 1/2 + v h: the root c in [1/2, 1] of 4c^3 - 3c = v^2 - 1
    written as c = 1/2 + v h; h lies in [0.353, 0.409]. The fit's error is < 7e-5;
    two Newton steps (`_ct_newton2`, derivative 12 h (1 + v h) >= 4.2) give h to
    rounding.
    """
    return ((-0.0028269 * v + 0.01523889) * v - 0.05456088) * v + 0.40818365


@njit(cache=True, inline="always", error_model="numpy")
def _ct_newton2(v1, h1, v3, h3):
    """One Newton step for 2 h^2 (3 + 2 v h) = 1 at (v1, h1) and at (v3, h3) with a
    single division: f1 / d1 = f1 d3 / (d1 d3) (a few ulps of the correction)."""
    vh1 = v1 * h1
    vh3 = v3 * h3
    f1 = 2.0 * h1 * h1 * (3.0 + 2.0 * vh1) - 1.0
    f3 = 2.0 * h3 * h3 * (3.0 + 2.0 * vh3) - 1.0
    d1 = 12.0 * h1 * (1.0 + vh1)
    d3 = 12.0 * h3 * (1.0 + vh3)
    inv = 1.0 / (d1 * d3)
    return h1 - f1 * d3 * inv, h3 - f3 * d1 * inv


@njit(cache=True, error_model="numpy")
def eig3_fast(c00, c01, c02, c11, c12, c22):
    """Eigenvalues (descending, clipped at 0) of a symmetric PSD 3x3, no trig calls.

    The trace-shifted, scaled trigonometric closed form (B = (C - qI)/p,
    r = det(B)/2 clamped to [-1, 1]), with cos(acos(r)/3) and cos(acos(r)/3 + 2pi/3)
    as 1/2 + v h(v) of v = sqrt(1 + r) and sqrt(1 - r) (the smallest root is minus
    the largest root for -r; h from `_ct_start` and two `_ct_newton2` steps):
    about 1.5x faster than acos + 2 cos and as accurate (double roots resolved to
    ~1e-8 lambda_1; `eigh3_accurate` refines). Four divisions and three square
    roots. The same arithmetic as `optimal_kernel`'s stages (`_lanes_stage1` to
    `_lanes_stage3`), so both give the same values bit for bit.
    """
    q, p, p2, r = _lanes_stage1(c00, c01, c02, c11, c12, c22)
    if p2 <= 0.0:
        v = max(q, 0.0)
        return v, v, v
    v1, h1, v3, h3 = _lanes_stage2(r)
    return _lanes_stage3(q, p, p2, v1, h1, v3, h3)


@njit(cache=True, inline="always", error_model="numpy")
def _eig3_lanes(c00, c01, c02, c11, c12, c22):
    """`eig3_fast` without branches (selects only), bit for bit the same values.

    Composed of three stages (`_lanes_stage1`, `_lanes_stage2`, `_lanes_stage3`)
    that `optimal_kernel` runs as three flat loops over its candidates: each
    loop vectorises, and its iterations are independent, so the long chain of
    square roots and divisions of one candidate overlaps with the next ones.
    """
    q, p, p2, r = _lanes_stage1(c00, c01, c02, c11, c12, c22)
    v1, h1, v3, h3 = _lanes_stage2(r)
    return _lanes_stage3(q, p, p2, v1, h1, v3, h3)


@njit(cache=True, inline="always", error_model="numpy")
def _lanes_stage1(c00, c01, c02, c11, c12, c22):
    """Trace shift q, scale p (and p^2) and the clamped half determinant r."""
    q = (c00 + c11 + c22) * _THIRD
    b00 = c00 - q
    b11 = c11 - q
    b22 = c22 - q
    p2 = b00 * b00 + b11 * b11 + b22 * b22 + 2.0 * (c01 * c01 + c02 * c02 + c12 * c12)
    p = math.sqrt(p2 * _SIXTH)
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
    r = 0.5 * det
    r = -1.0 if r < -1.0 else r
    r = 1.0 if r > 1.0 else r
    return q, p, p2, r


@njit(cache=True, inline="always", error_model="numpy")
def _lanes_stage2(r):
    """v1 = sqrt(1 + r), v3 = sqrt(1 - r) and the first Newton iterates h1, h3."""
    v1 = math.sqrt(1.0 + r)
    v3 = math.sqrt(1.0 - r)
    h1, h3 = _ct_newton2(v1, _ct_start(v1), v3, _ct_start(v3))
    return v1, h1, v3, h3


@njit(cache=True, inline="always", error_model="numpy")
def _lanes_stage3(q, p, p2, v1, h1, v3, h3):
    """Second Newton step, the three eigenvalues, ordered and clipped."""
    h1, h3 = _ct_newton2(v1, h1, v3, h3)
    l1 = q + 2.0 * p * (0.5 + v1 * h1)
    l3 = q - 2.0 * p * (0.5 + v3 * h3)
    l2 = 3.0 * q - l1 - l3
    l2 = l1 if l2 > l1 else l2
    l2 = l3 if l2 < l3 else l2
    flat = p2 <= 0.0
    v = q if q > 0.0 else 0.0
    l1 = v if flat else (l1 if l1 > 0.0 else 0.0)
    l2 = v if flat else (l2 if l2 > 0.0 else 0.0)
    l3 = v if flat else (l3 if l3 > 0.0 else 0.0)
    return l1, l2, l3


#: intervals of the chord table of -t ln t on [0, 1]
_CHORD_N = 1024


def _chord_table(n):
    """Intercepts and slopes of the chords of the concave -t ln t on [j/n, (j+1)/n].

    A chord lies below a concave function on its interval, so A[j] + B[j] t is a
    lower bound of -t ln t for t in [j/n, (j+1)/n] (error at most 1/(e n) on the
    first interval, 1/(8 n) elsewhere); the last chord serves t slightly above 1.
    """
    t = np.arange(n + 1, dtype=np.float64) / n
    f = np.zeros(n + 1)
    f[1:] = -t[1:] * np.log(t[1:])
    f[n] = 0.0
    slope = (f[1:] - f[:-1]) * n
    return np.ascontiguousarray(f[:-1] - slope * t[:-1]), np.ascontiguousarray(slope)


_CHORD_A, _CHORD_B = _chord_table(_CHORD_N)


@njit(cache=True, inline="always", error_model="numpy")
def _chord_bound(t):
    """Lower bound of -t ln t for t in [0, 1 + a few ulps] (a table chord, no log)."""
    j = min(int(t * _CHORD_N), _CHORD_N - 1)
    return _CHORD_A[j] + _CHORD_B[j] * t


#: absolute margin (in criterion units) a lower bound must clear to skip a choice
_PRUNE_MARGIN = 1e-9

#: cells of `edim_table` along p/q and along sqrt(1 + r)
EDIM_TABLE_SHAPE = (256, 256)
#: what a table entry stays below the cell's smallest E_dim (covers eig3_fast's
#: rounding: its eigenvalues are those of the stage-1 (q, p, r) to ~1e-8 lambda_1
#: at worst, which moves each -t ln t by at most -d ln d ~ 2e-7 for d = 1e-8)
_TABLE_MARGIN = 2e-6


def _lps_of_cell(rho, theta):
    """Linearity, planarity, scattering of the eigenvalues q (1 + 2 rho cos(theta +
    2 pi j / 3)), theta in [0, pi/3] (exact formulas, unclipped)."""
    den = 1.0 + 2.0 * rho * np.cos(theta)
    lin = 2.0 * math.sqrt(3.0) * rho * np.sin(math.pi / 3.0 - theta) / den
    pla = 2.0 * math.sqrt(3.0) * rho * np.sin(theta) / den
    sca = (1.0 + 2.0 * rho * np.cos(theta + 2.0 * math.pi / 3.0)) / den
    return lin, pla, sca


def _min_tlogt(lo, hi):
    """Smallest -t ln t over [lo, hi] (clipped to [0, 1]): at an end, as it is concave."""
    ends = np.clip(np.stack([lo, hi]), 0.0, 1.0)
    safe = np.where(ends > 0.0, ends, 1.0)
    return np.min(-ends * np.log(safe), axis=0)


def edim_table(n_rho: int = EDIM_TABLE_SHAPE[0], n_v: int = EDIM_TABLE_SHAPE[1]) -> np.ndarray:
    """Certified lower bounds of E_dim (Eq. 5.7) over cells of the closed form's inputs.

    `eig3_fast` writes the eigenvalues as q (1 + 2 rho c_j) with rho = p/q in
    [0, 1] (lambda_3 >= 0 needs rho <= 1) and c_j = cos(theta + 2 pi j/3),
    theta = acos(v^2 - 1)/3, v = sqrt(1 + r) in [0, sqrt 2]. Entry (i, j) bounds
    E_dim from below for rho in [i, i + 1] / n_rho and v in [j, j + 1] sqrt(2) / n_v.
    With theta: linearity 2 sqrt(3) rho sin(pi/3 - theta) / (1 + 2 rho cos theta)
    grows with rho and falls with theta, planarity 2 sqrt(3) rho sin(theta) / (...)
    grows with both, and scattering falls with rho and, in theta, falls then rises
    (its derivative has the sign of -(cos(theta + pi/3) + rho)), so the exact range
    of each over a cell comes from its corners and, for the smallest scattering,
    theta* = acos(-rho) - pi/3. Where lambda_3 < 0 in the cell (clipped to 0 by the
    solver: scattering 0, planarity 1 - linearity) the ranges widen to hold that.
    -t ln t is concave, so its smallest value on a range is at an end; the sum of
    the three is a lower bound of E_dim on the cell, less `_TABLE_MARGIN`. Cells
    are widened by 1e-10 on every side for the rounding of the index.

    Returns
    -------
    table : ndarray of shape (n_rho, n_v), float64
    """
    widen = 1e-10
    ra = np.maximum(np.arange(n_rho) / n_rho - widen, 0.0)[:, None]
    rb = (np.arange(1, n_rho + 1) / n_rho + widen)[:, None]
    v = np.arange(n_v + 1) * (math.sqrt(2.0) / n_v)
    t_lo = np.arccos(np.clip((v[1:] + widen) ** 2 - 1.0, -1.0, 1.0)) / 3.0 - widen
    t_hi = np.arccos(np.clip(v[:-1] ** 2 - 1.0, -1.0, 1.0)) / 3.0 + widen
    ta = np.maximum(t_lo, 0.0)[None, :]
    tb = np.minimum(t_hi, math.pi / 3.0)[None, :]
    lin_lo = _lps_of_cell(ra, tb)[0]
    lin_hi = _lps_of_cell(rb, ta)[0]
    pla_lo = _lps_of_cell(ra, ta)[1]
    pla_hi = _lps_of_cell(rb, tb)[1]
    sca_hi = np.maximum(_lps_of_cell(ra, ta)[2], _lps_of_cell(ra, tb)[2])
    t_star = np.clip(np.arccos(-np.minimum(rb, 1.0)) - math.pi / 3.0, ta, tb)
    sca_lo = _lps_of_cell(rb, t_star)[2]
    clipped = sca_lo < 0.0
    pla_lo = np.where(clipped, np.minimum(pla_lo, 1.0 - lin_hi), pla_lo)
    sca_lo = np.maximum(sca_lo, 0.0)
    sca_hi = np.maximum(sca_hi, 0.0)
    bound = _min_tlogt(lin_lo, lin_hi) + _min_tlogt(pla_lo, pla_hi) + _min_tlogt(sca_lo, sca_hi)
    return np.ascontiguousarray(bound - _TABLE_MARGIN)


@njit(cache=True, inline="always", error_model="numpy")
def _lps_ratios(l1, l2, l3):
    """Linearity, planarity, scattering as the search computes them (one division)."""
    il1 = 1.0 / l1
    return (l1 - l2) * il1, (l2 - l3) * il1, l3 * il1


@njit(cache=True, inline="always", error_model="numpy")
def _edim_of(lin, pla, sca):
    """E_dim (Eq. 5.7) of the search's ratios (-t ln t as 0 at t <= 0)."""
    lnl = math.log(lin) if lin > 0.0 else 0.0
    lnp = math.log(pla) if pla > 0.0 else 0.0
    lns = math.log(sca) if sca > 0.0 else 0.0
    return -(lin * lnl + pla * lnp + sca * lns)


@njit(cache=True, inline="always", error_model="numpy")
def _eig_features_row(out, i, c00, c01, c02, c11, c12, c22, m1, m2):
    """Eigen-decomposition (`eigh3_accurate`) and features of one covariance into row
    ``i`` of the packed output (`N_OUT` columns); False (row NaN) when lambda_1 = 0."""
    l1, l2, l3, e1x, e1y, e1z, e3x, e3y, e3z = eigh3_accurate(c00, c01, c02, c11, c12, c22)
    if not l1 > 0.0:
        for c in range(N_OUT):
            out[i, c] = np.nan
        return False
    s = l1 + l2 + l3
    lin = (l1 - l2) / l1
    pla = (l2 - l3) / l1
    sca = l3 / l1
    e1 = l1 / s
    e2 = l2 / s
    e3 = l3 / s
    out[i, 0] = l1
    out[i, 1] = l2
    out[i, 2] = l3
    out[i, 3] = e1x
    out[i, 4] = e1y
    out[i, 5] = e1z
    out[i, 6] = e3x
    out[i, 7] = e3y
    out[i, 8] = e3z
    out[i, 9] = lin
    out[i, 10] = pla
    out[i, 11] = sca
    out[i, 12] = 0.0 - (_xlogx(lin) + _xlogx(pla) + _xlogx(sca))
    out[i, 13] = np.cbrt(e1 * e2 * e3)
    out[i, 14] = 1.0 - (e1 - e3) / e1
    out[i, 15] = e3 / (e1 + e2 + e3)
    out[i, 16] = 0.0 - (_xlogx(e1) + _xlogx(e2) + _xlogx(e3))
    out[i, 17] = s
    out[i, 18] = 1.0 - abs(e3z)
    out[i, 19] = _pow_even(1.0 - l2 / l1, m1) + 1.0 - _pow_even(1.0 - l3 / l1, m2)
    return True


@njit(cache=True, inline="always", error_model="numpy")
def _three_distinct_k(ws, pr, ys, kmax):
    """Smallest k such that the first k neighbours (coordinates ``ys``) hold three
    distinct points of positive weight ``ws[pr]``; kmax + 1 if none (no candidate)."""
    nd = 0
    d1 = -1
    d2 = -1
    for j in range(kmax):
        if ws[pr, j] > 0.0:
            nd, d1, d2 = _count_distinct(ys, j, nd, d1, d2)
            if nd == 3:
                return j + 1
    return kmax + 1


@njit(cache=True, inline="always", error_model="numpy")
def _count_distinct(ys, j, nd, d1, d2):
    """Count weighted point j (row of ``ys``) among the distinct points seen so far:
    ``nd`` (up to 3) of them, the first two at rows ``d1``, ``d2``; returns the
    updated (nd, d1, d2)."""
    if nd == 0:
        return 1, j, d2
    if nd == 1:
        if _same(ys, j, d1):
            return nd, d1, d2
        return 2, d1, j
    if nd == 2 and not _same(ys, j, d1) and not _same(ys, j, d2):
        return 3, d1, d2
    return nd, d1, d2


@njit(cache=True, inline="always", error_model="numpy")
def _cov_from_sums(sw, sx, sy, sz, sxx, sxy, sxz, syy, syz, szz, mx, my, mz):
    """Eq. 5.4 from the moments about the point itself: C = Syy - Sy m^T - m Sy^T
    + W m m^T (W = sw, Sy = (sx, sy, sz), Syy the six sums of w y y^T, m the
    unweighted mean); returns c00, c01, c02, c11, c12, c22. Shared by `_choice_cov`
    and `optimal_kernel`, so both form the same covariance bit for bit."""
    gx = sw * mx - sx
    gy = sw * my - sy
    gz = sw * mz - sz
    return (
        (sxx - sx * mx) + mx * gx,
        (sxy - sx * my) + mx * gy,
        (sxz - sx * mz) + mx * gz,
        (syy - sy * my) + my * gy,
        (syz - sy * mz) + my * gz,
        (szz - sz * mz) + mz * gz,
    )


#: Cephes' atan: P(z) / Q(z) coefficients (z = x^2, |x| <= 0.66), Q monic
_ATAN_P = (
    -8.750608600031904122785e-1,
    -1.615753718733365076637e1,
    -7.500855792314704667340e1,
    -1.228866684490136173410e2,
    -6.485021904942025371773e1,
)
_ATAN_Q = (
    2.485846490142306297962e1,
    1.650270098316988542046e2,
    4.328810604912902668951e2,
    4.853903996359136964868e2,
    1.945506571482613964425e2,
)
#: pi/2 - fl(pi/2), added where Cephes adds it
_ATAN_MOREBITS = 6.123233995736765886130e-17


@njit(cache=True, inline="always", error_model="numpy")
def _atan2_nonneg(y, x):
    """atan2(y, x) for y, x >= 0 (not both 0), in [0, pi/2]; NaN in, NaN out.

    Cephes' atan (relative error ~2e-16) of min/max after the reflection
    atan(t) = pi/2 - atan(1/t), written with selects only, so loops over it
    vectorise (libm's atan2 is a call per value: ~60 % of the angles' cost).
    """
    hi = y if y > x else x
    lo = x if y > x else y
    r = lo / hi
    big = r > 0.66
    t = (r - 1.0) / (r + 1.0) if big else r
    z = t * t
    p = _ATAN_P[0]
    p = p * z + _ATAN_P[1]
    p = p * z + _ATAN_P[2]
    p = p * z + _ATAN_P[3]
    p = p * z + _ATAN_P[4]
    q = z + _ATAN_Q[0]
    q = q * z + _ATAN_Q[1]
    q = q * z + _ATAN_Q[2]
    q = q * z + _ATAN_Q[3]
    q = q * z + _ATAN_Q[4]
    a = t + t * (z * p / q)
    a = (0.7853981633974483 + (a + 0.5 * _ATAN_MOREBITS)) if big else a
    a = (1.5707963267948966 - a + _ATAN_MOREBITS) if y > x else a
    return a if (y == y and x == x) else np.nan


@njit(cache=True, inline="always", error_model="numpy")
def _normal_angle(nx, ny, nz, mx, my, mz):
    """Angle between unit normals n and m: 2 atan2(|n - m|, |n + m|), below
    ``ANGLE_ZERO`` exactly 0 (NaN stays NaN)."""
    dx = nx - mx
    dy = ny - my
    dz = nz - mz
    sx = nx + mx
    sy = ny + my
    sz = nz + mz
    x = 2.0 * _atan2_nonneg(
        math.sqrt(dx * dx + dy * dy + dz * dz), math.sqrt(sx * sx + sy * sy + sz * sz)
    )
    if x < ANGLE_ZERO:
        x = 0.0
    return x


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

    Per point the angles to the kmax sorted neighbours' normals are computed once
    (`_normal_angle`, as `angles_kernel`). For every distinct a the neighbours with
    angle <= a (a bit mask) and the smallest angle above a are found; a pair (a, b)
    whose weights are then all 0/1 and select the same neighbours as an earlier
    pair is dropped (identical values; the earlier pair wins the tie); only the
    remaining pairs get their weights (the cosine ramp only where an angle lies in
    (a, b)). k then grows by one neighbour at a time while the weighted moments
    (sum w, sum w y, sum w y y^T about the point itself) of every pair and the
    unweighted sum of y are updated, so each covariance costs O(1); the
    covariances of all choices are stored. Their eigenvalues are `eig3_fast`'s
    values, from a branch-free copy in three flat loops the compiler vectorises
    (`_lanes_stage1` to `_lanes_stage3`). For E_dim (criterion 0) with a table
    ``tab`` (`edim_table`), the first stage's (q, p, r) of each choice pick a cell
    whose entry is a certified lower bound of its E_dim; the choice with the
    smallest entry gets its exact E_dim, and only the choices whose entry does not
    exceed that value by `_PRUNE_MARGIN` (a few of ~100) go through the other two
    stages. For those, a logarithm-free lower bound (chords of -t ln t,
    `_chord_bound`) follows, and only choices whose bound does not exceed the best
    value found so far by `_PRUNE_MARGIN` get the criterion with its three
    logarithms, the smallest bound first. Every choice skipped is certified worse,
    so the result is the exact argmin of the criterion over all choices. Ties:
    smallest k, then a, then b. Criterion 0: E_dim; 1: eigenentropy (``tab`` of
    shape (0, 0): every choice goes through all stages). Without normals there is
    one pair with all weights 1.

    The winner's covariance is the one stored for it (`_cov_from_sums`): the
    weights are those of `cosine_sigmoid_scalar`, the sums and the formula those
    of `_choice_cov`, so it is the covariance `fused_kernel` builds at that
    choice, bit for bit; row i of ``out`` (N, `N_OUT`) receives its
    eigen-decomposition and features (`_eig_features_row`), so the result equals
    the search followed by `fused_kernel` at the chosen triple bit for bit,
    without the angle table and the second pass. ``reason``, ``best_k`` (-1:
    none) and ``best_pair`` (-1) per point; rows without a valid choice are NaN.
    Points are visited in ``order`` (see `pointatlas._core._sort.morton_order`);
    indices must lie in [0, N).
    """
    n = idx.shape[0]
    n_pairs = pair_a.shape[0] if use_normals else 1
    dedupe = use_normals and kmax <= 64
    # the mask of all kmax neighbours (bit j: neighbour j)
    all_bits = np.uint64(0xFFFFFFFFFFFFFFFF) >> np.uint64(64 - min(kmax, 64))
    nk = kmax - kmin + 1
    nblocks = (n + _BLOCK - 1) // _BLOCK
    # the table flat, with -inf (no bound) at its end for choices outside it
    n_rho = tab.shape[0]
    n_v = tab.shape[1]
    tabf = np.full(n_rho * n_v + 1, -np.inf)
    tabf[: n_rho * n_v] = tab.ravel()
    use_tab = criterion == 0 and n_rho * n_v > 0
    v_scale = n_v / math.sqrt(2.0)
    fv_max = float(n_v - 1)
    n_cells = float(n_rho * n_v)
    for blk in prange(nblocks):
        ys = np.empty((kmax, 3))
        angrow = np.zeros(kmax)
        nb = np.empty((3, kmax))
        ws = np.ones((n_pairs, kmax))
        act = np.empty(n_pairs, dtype=np.int64)
        nbp = np.empty(n_pairs, dtype=np.int64)
        uu = np.empty(n_pairs * kmax)
        masks = np.empty(n_pairs, dtype=np.uint64)
        cv = np.empty((6, nk * n_pairs))
        lam = np.empty((3, nk * n_pairs))
        ev = np.empty((8, nk * n_pairs))
        rt = np.empty((3, nk * n_pairs))
        lbv = np.empty(nk * n_pairs)
        mk = np.empty((3, nk))
        fin_k = np.empty(nk, dtype=np.bool_)
        qk = np.empty(nk * n_pairs, dtype=np.int64)
        qp = np.empty(nk * n_pairs, dtype=np.int64)
        tb = np.empty(nk * n_pairs)
        sl = np.empty(nk * n_pairs, dtype=np.int64)
        cf = np.empty(nk * n_pairs)
        e1 = np.empty((4, nk * n_pairs))
        t_end = min(n, (blk + 1) * _BLOCK)
        for t in range(blk * _BLOCK, t_end):
            if t + _AHEAD < t_end:
                ia = order[t + _AHEAD]
                for c in range(0, kmax, 8):
                    prefetch_read(idx, ia, c)
                prefetch_read(idx, ia, kmax - 1)
                prefetch_write(out, ia, 0)
                prefetch_write(out, ia, N_OUT - 1)
            if t + _AHEAD // 2 < t_end:
                ib = order[t + _AHEAD // 2]
                for j in range(kmax):
                    prefetch_read(points, idx[ib, j], 0)
                    if use_normals:
                        prefetch_read(normals, idx[ib, j], 0)
            i = order[t]
            best_k[i] = -1
            best_pair[i] = -1
            ok = _gather(points, idx, i, kmax, ys)
            if use_normals:
                nx = normals[i, 0]
                ny = normals[i, 1]
                nz = normals[i, 2]
                # the neighbours' normals first, then the angles in a flat loop
                # (vectorised; x is NaN or in [0, pi])
                for j in range(kmax):
                    m = idx[i, j]
                    nb[0, j] = normals[m, 0]
                    nb[1, j] = normals[m, 1]
                    nb[2, j] = normals[m, 2]
                n_bad = 0
                for j in range(kmax):
                    x = _normal_angle(nx, ny, nz, nb[0, j], nb[1, j], nb[2, j])
                    angrow[j] = x
                    n_bad += 0 if x == x else 1
                if n_bad > 0:
                    ok = False
            if not ok:
                reason[i] = REASON_NONFINITE
                for c in range(N_OUT):
                    out[i, c] = np.nan
                out[i, 12] = np.inf
                continue
            x_max = 0.0
            if use_normals:
                for j in range(kmax):
                    x = angrow[j]
                    x_max = x if x > x_max else x_max
            n_act = 0
            n_masks = 0
            n_nb = 0
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
                                x = angrow[j]
                                c = x if x > a else np.inf
                                x_next = c if c < x_next else x_next
                            if dedupe:
                                for j in range(kmax):
                                    bit = np.uint64(1) if angrow[j] <= a else np.uint64(0)
                                    mask |= bit << np.uint64(j)
                    binary = x_next >= b  # no angle in (a, b): weights 0/1
                    if dedupe and binary:
                        seen = False
                        for mm in range(n_masks):
                            if masks[mm] == mask:
                                seen = True
                                break
                        if seen:
                            continue
                        masks[n_masks] = mask
                        n_masks += 1
                    if binary:
                        for j in range(kmax):
                            ws[pr, j] = 1.0 if angrow[j] <= a else 0.0
                    else:
                        # the ramp's argument now, the ramp below for all such pairs
                        inv = 1.0 / (b - a)
                        base = n_nb * kmax
                        for j in range(kmax):
                            uu[base + j] = (angrow[j] - a) * inv
                        nbp[n_nb] = pr
                        n_nb += 1
                act[n_act] = pr
                n_act += 1
            # the cosine ramps of every pair with angles inside (a, b) in one flat
            # loop (vectorised, and the polynomials of different pairs overlap)
            for u in range(n_nb * kmax):
                uu[u] = _sigmoid_ramp(uu[u])
            for u in range(n_nb):
                pr = nbp[u]
                a = pair_a[pr]
                b = pair_b[pr]
                for j in range(kmax):
                    x = angrow[j]
                    w = uu[u * kmax + j]
                    w = 0.0 if x >= b else w
                    w = 1.0 if x <= a else w
                    ws[pr, j] = w
            # unweighted barycentres of the k nearest neighbours
            ux = 0.0
            uy = 0.0
            uz = 0.0
            for j in range(kmax):
                ux += ys[j, 0]
                uy += ys[j, 1]
                uz += ys[j, 2]
                k = j + 1
                if k >= kmin:
                    mk[0, k - kmin] = ux / k
                    mk[1, k - kmin] = uy / k
                    mk[2, k - kmin] = uz / k
                    fin_k[k - kmin] = math.isfinite(ux + uy + uz)
            # prefix moments of every active pair at every k >= kmin, pair by pair
            # with the ten sums in registers (the same additions in the same order
            # as one running update per neighbour); only the choices with at least
            # three distinct weighted points are kept, as candidates q
            n_q = 0
            for s in range(n_act):
                pr = act[s]
                # candidates from the first k with three distinct weighted points
                ks = max(_three_distinct_k(ws, pr, ys, kmax), kmin)
                if ks > kmax:
                    continue
                s0 = s1 = s2 = s3 = s4 = s5 = s6 = s7 = s8 = s9 = 0.0
                for j in range(kmax):
                    w = ws[pr, j]
                    yx = ys[j, 0]
                    yy = ys[j, 1]
                    yz = ys[j, 2]
                    s0 += w
                    s1 += w * yx
                    s2 += w * yy
                    s3 += w * yz
                    s4 += w * yx * yx
                    s5 += w * yx * yy
                    s6 += w * yx * yz
                    s7 += w * yy * yy
                    s8 += w * yy * yz
                    s9 += w * yz * yz
                    if j + 1 >= ks:
                        q = n_q
                        n_q += 1
                        c = _cov_from_sums(
                            s0, s1, s2, s3, s4, s5, s6, s7, s8, s9,
                            mk[0, j + 1 - kmin], mk[1, j + 1 - kmin], mk[2, j + 1 - kmin],
                        )  # fmt: skip
                        cv[0, q] = c[0]
                        cv[1, q] = c[1]
                        cv[2, q] = c[2]
                        cv[3, q] = c[3]
                        cv[4, q] = c[4]
                        cv[5, q] = c[5]
                        qk[q] = j + 1
                        qp[q] = pr
            # C = Syy - Sy m^T - m Sy^T + W m m^T (m the unweighted mean), eigenvalues
            for q in range(n_q):
                ev[0, q], ev[1, q], ev[2, q], ev[3, q] = _lanes_stage1(
                    cv[0, q], cv[1, q], cv[2, q], cv[3, q], cv[4, q], cv[5, q]
                )
            # certified lower bounds of E_dim from the (p/q, sqrt(1 + r)) cell of each
            # candidate (`edim_table`); only the candidates whose bound does not exceed
            # the exact E_dim of the one with the smallest bound go on (NaN passes),
            # their stage-1 values copied into e1 and their indices into sl
            ns = 0
            ub = np.inf
            if use_tab and n_q > 0:
                # the cell of each candidate as a float (the loop vectorises; AVX2 has
                # no 64-bit integer product), bad ones: the table's last entry, -inf
                for q in range(n_q):
                    rho = ev[1, q] / ev[0, q]
                    v1 = math.sqrt(1.0 + ev[3, q])
                    good = rho >= 0.0 and rho < 1.0 and ev[2, q] > 0.0 and v1 <= 2.0
                    fr = np.floor(rho * n_rho)
                    fv = np.floor(v1 * v_scale)
                    fv = fv_max if fv > fv_max else fv
                    cf[q] = fr * n_v + fv if good else n_cells
                tmin = np.inf
                for q in range(n_q):
                    tq = tabf[int(cf[q])]
                    tb[q] = tq
                    tmin = tq if tq < tmin else tmin
                q0 = 0
                for q in range(n_q):
                    if tb[q] == tmin:
                        q0 = q
                        break
                v1, h1, v3, h3 = _lanes_stage2(ev[3, q0])
                l1, l2, l3 = _lanes_stage3(ev[0, q0], ev[1, q0], ev[2, q0], v1, h1, v3, h3)
                lin, pla, sca = _lps_ratios(l1, l2, l3)
                ub = _edim_of(lin, pla, sca) + _PRUNE_MARGIN
            for q in range(n_q):
                sl[ns] = q
                ns += 0 if (use_tab and tb[q] > ub) else 1
            for s in range(ns):
                q = sl[s]
                e1[0, s] = ev[0, q]
                e1[1, s] = ev[1, q]
                e1[2, s] = ev[2, q]
                e1[3, s] = ev[3, q]
            for s in range(ns):
                ev[4, s], ev[5, s], ev[6, s], ev[7, s] = _lanes_stage2(e1[3, s])
            for s in range(ns):
                l1, l2, l3 = _lanes_stage3(
                    e1[0, s], e1[1, s], e1[2, s], ev[4, s], ev[5, s], ev[6, s], ev[7, s]
                )
                lam[0, s] = l1
                lam[1, s] = l2
                lam[2, s] = l3
                # the arguments of -t ln t in the criterion (as it computes them)
                if criterion == 1:
                    sm = l1 + l2 + l3
                    rt[0, s] = l1 / sm
                    rt[1, s] = l2 / sm
                    rt[2, s] = l3 / sm
                else:
                    rt[0, s], rt[1, s], rt[2, s] = _lps_ratios(l1, l2, l3)
            # the bounds and the smallest one; the smallest bound first, then every
            # choice it does not rule out
            n_zero = 0
            for q in range(ns):
                lb = _chord_bound(rt[0, q]) + _chord_bound(rt[1, q]) + _chord_bound(rt[2, q])
                zero = not lam[0, q] > 0.0  # lambda_1 = 0: no choice
                lbv[q] = np.inf if zero else lb
                n_zero += 1 if zero else 0
            code = REASON_ZERO_EIGENSUM if n_zero > 0 else REASON_FEW_DISTINCT
            lb0 = np.inf
            for q in range(ns):
                lb0 = lbv[q] if lbv[q] < lb0 else lb0
            q0 = -1
            if lb0 < np.inf:
                for q in range(ns):
                    if lbv[q] == lb0:
                        q0 = q
                        break
            bv = np.inf
            bk = -1
            bp = -1
            bq = -1
            if q0 >= 0:
                for step in range(ns + 1):
                    q = q0 if step == 0 else step - 1
                    if step > 0 and (q == q0 or not lbv[q] <= bv + _PRUNE_MARGIN):
                        continue
                    if criterion == 1:
                        val = -(_xlogx(rt[0, q]) + _xlogx(rt[1, q]) + _xlogx(rt[2, q]))
                    else:
                        val = _edim_of(rt[0, q], rt[1, q], rt[2, q])
                    k = qk[sl[q]]
                    pr = qp[sl[q]]
                    if val < bv or (val == bv and (k < bk or (k == bk and pr < bp))):
                        bv = val
                        bk = k
                        bp = pr
                        bq = sl[q]
            if bk < 0:
                reason[i] = code
                for c in range(N_OUT):
                    out[i, c] = np.nan
                out[i, 12] = np.inf
                continue
            # the winner's covariance from its stored moments: the very numbers
            # `_choice_cov` (`fused_kernel`) computes at this choice (same weights,
            # sums and formula), and its features
            code = REASON_OK if fin_k[bk - kmin] else REASON_NONFINITE
            c00, c01, c02, c11, c12, c22 = (
                cv[0, bq],
                cv[1, bq],
                cv[2, bq],
                cv[3, bq],
                cv[4, bq],
                cv[5, bq],
            )
            if code == REASON_OK and not _eig_features_row(
                out, i, c00, c01, c02, c11, c12, c22, m1, m2
            ):
                code = REASON_ZERO_EIGENSUM
            reason[i] = code
            if code == REASON_OK:
                best_k[i] = bk
                best_pair[i] = bp
            else:
                for c in range(N_OUT):
                    out[i, c] = np.nan
                out[i, 12] = np.inf


@njit(cache=True, error_model="numpy")
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


@njit(cache=True, error_model="numpy")
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


@njit(cache=True, inline="always", error_model="numpy")
def _prefetch_row(arr, row):
    """Prefetch every cache line of the row ``arr[row]`` (2-D float64/int64 array)."""
    kk = arr.shape[1]
    for c in range(0, kk, 8):
        prefetch_read(arr, row, c)
    prefetch_read(arr, row, kk - 1)


@njit(cache=True, inline="always", error_model="numpy")
def _prefetch_out(arr, row):
    kk = arr.shape[1]
    for c in range(0, kk, 8):
        prefetch_write(arr, row, c)
    prefetch_write(arr, row, kk - 1)


#: columns of the packed output of `fused_kernel`: eigenvalues (3), eigenvector_1 (3),
#: eigenvector_3 (3), then the `N_FEATURES` features (one row per point: the
#: kernel's scattered writes touch 3 cache lines per point instead of 7)
N_OUT = 9 + N_FEATURES


@njit(cache=True, inline="always", error_model="numpy")
def _pow_even(x, m):
    """x ** m for an integer m >= 0 by repeated squaring."""
    r = 1.0
    while m > 0:
        if m & 1:
            r *= x
        x *= x
        m >>= 1
    return r


@njit(cache=True, inline="always", error_model="numpy")
def _choice_cov(points, idx, i, kk, ang, arow, use_normals, a, b):
    """Reason code and covariance (Eq. 5.4: c00, c01, c02, c11, c12, c22) of point i
    at one choice: its first ``kk`` neighbours, weights `cosine_sigmoid_scalar` of
    the angles in row ``arow`` of ``ang`` (all 1 without normals).

    One pass accumulating the moments about the point itself (sum w, sum w y,
    sum w y y^T) and the unweighted sum of y, from which Eq. 5.4 follows; the
    distinct weighted points are counted on absolute coordinates. Codes in order of
    precedence: bad index, non-finite, zero weights, fewer than 3 distinct points
    (covariance 0 then). `optimal_kernel` forms the same sums in the same order
    and the covariance with the same formula (`_cov_from_sums`), so both give the
    same covariance bit for bit.
    """
    px = points[i, 0]
    py = points[i, 1]
    pz = points[i, 2]
    finite = math.isfinite(px) and math.isfinite(py) and math.isfinite(pz)
    bad_index = False
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
    for j in range(kk):
        m = idx[i, j]
        if m < 0 or m >= points.shape[0]:
            bad_index = True
            m = i
        yx = points[m, 0] - px
        yy = points[m, 1] - py
        yz = points[m, 2] - pz
        ux += yx
        uy += yy
        uz += yz
        w = 1.0
        if use_normals:
            x = ang[arow, j]
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
    if bad_index:
        code = REASON_BAD_INDEX
    elif not (finite and math.isfinite(ux + uy + uz)):
        code = REASON_NONFINITE
    elif sw <= 0.0:
        code = REASON_ZERO_WEIGHTS
    elif n_distinct < 3:
        code = REASON_FEW_DISTINCT
    if code != REASON_OK:
        return code, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
    c00, c01, c02, c11, c12, c22 = _cov_from_sums(
        sw, sx, sy, sz, sxx, sxy, sxz, syy, syz, szz, ux / kk, uy / kk, uz / kk
    )
    return code, c00, c01, c02, c11, c12, c22


@njit(parallel=True, cache=True, error_model="numpy")
def fused_kernel(points, idx, order, k_of, ang, use_normals, a_of, b_of, m1, m2, out, reason):
    """One (a, b, k) choice per point: covariance, eigen-decomposition and features.

    Single pass over the neighbours accumulating the moments about the point itself
    (sum w, sum w y, sum w y y^T) and the unweighted sum of y; Eq. 5.4 follows
    from them. Eigenvalues and vectors by `eigh3_accurate`; features as in
    `features_kernel`. Row i of ``out`` (N, `N_OUT`) receives the eigenvalues,
    eigenvector_1, eigenvector_3 and the features of point i; degenerate rows are
    NaN. Points are visited in ``order`` (see `pointatlas._core._sort.morton_order`) in blocks:
    first the covariances of the block (the index-table and output rows of the
    point `_AHEAD` places later and the neighbour coordinates of the point
    `_AHEAD` / 2 places later prefetched), then the eigen-decompositions and
    features, a loop without memory gathers whose iterations overlap. ``k_of``,
    ``a_of`` and ``b_of`` have one entry per point or a single entry for all. A
    neighbour index outside [0, N) gives reason `REASON_BAD_INDEX` (the caller
    raises).
    """
    n = idx.shape[0]
    n_pts = points.shape[0]
    per_k = k_of.shape[0] > 1
    per_ab = a_of.shape[0] > 1
    nblocks = (n + _BLOCK - 1) // _BLOCK
    for blk in prange(nblocks):
        t0 = blk * _BLOCK
        t_end = min(n, t0 + _BLOCK)
        cov = np.empty((_BLOCK, 6))
        codes = np.empty(_BLOCK, dtype=np.uint8)
        for t in range(t0, t_end):
            if t + _AHEAD < t_end:
                ia = order[t + _AHEAD]
                _prefetch_row(idx, ia)
                if use_normals:
                    _prefetch_row(ang, ia)
                _prefetch_out(out, ia)
            if t + _AHEAD // 2 < t_end:
                ib = order[t + _AHEAD // 2]
                for j in range(k_of[ib] if per_k else k_of[0]):
                    mb = idx[ib, j]
                    if 0 <= mb < n_pts:
                        prefetch_read(points, mb, 0)
            i = order[t]
            kk = k_of[i] if per_k else k_of[0]
            a = a_of[i] if per_ab else a_of[0]
            b = b_of[i] if per_ab else b_of[0]
            r = t - t0
            code, cov[r, 0], cov[r, 1], cov[r, 2], cov[r, 3], cov[r, 4], cov[r, 5] = _choice_cov(
                points, idx, i, kk, ang, i, use_normals, a, b
            )
            codes[r] = code
        for t in range(t0, t_end):
            i = order[t]
            r = t - t0
            code = codes[r]
            if code == REASON_OK and not _eig_features_row(
                out, i, cov[r, 0], cov[r, 1], cov[r, 2], cov[r, 3], cov[r, 4], cov[r, 5], m1, m2
            ):
                code = REASON_ZERO_EIGENSUM
            reason[i] = code
            if code != REASON_OK:
                for c in range(N_OUT):
                    out[i, c] = np.nan
