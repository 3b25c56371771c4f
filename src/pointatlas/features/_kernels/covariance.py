"""Weighted covariances of neighbourhoods (thesis Eq. 5.4; numba, validated input).

`choice_cov` (one point at one (a, b, k) choice) and the search's running sums
share `add_moments` and `cov_from_sums`, so both form the same covariance bit for bit.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from .layout import (
    BLOCK,
    REASON_BAD_INDEX,
    REASON_FEW_DISTINCT,
    REASON_NONFINITE,
    REASON_OK,
    REASON_ZERO_WEIGHTS,
)
from .math_helpers import cosine_sigmoid_scalar

__all__ = [
    "add_moments",
    "choice_cov",
    "count_distinct",
    "cov_from_sums",
    "covariance_kernel",
    "gather_offsets",
    "three_distinct_k",
]


@njit(cache=True, error_model="numpy")
def _same(ys, j, m):
    return ys[j, 0] == ys[m, 0] and ys[j, 1] == ys[m, 1] and ys[j, 2] == ys[m, 2]


@njit(cache=True, error_model="numpy")
def gather_offsets(points, idx, i, kk, ys):
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
        n_distinct, first, second = count_distinct(ys, j, n_distinct, first, second)
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
    nblocks = (n + BLOCK - 1) // BLOCK
    for blk in prange(nblocks):
        ys = np.empty((kk, 3))
        ws = np.ones(kk)
        a = np.empty((3, 3))
        for i in range(blk * BLOCK, min(n, (blk + 1) * BLOCK)):
            ok = gather_offsets(points, idx, i, kk, ys)
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


@njit(cache=True, inline="always", error_model="numpy")
def three_distinct_k(ws, pr, ys, kmax):
    """Smallest k such that the first k neighbours (coordinates ``ys``) hold three
    distinct points of positive weight ``ws[pr]``; kmax + 1 if none (no candidate)."""
    nd = 0
    d1 = -1
    d2 = -1
    for j in range(kmax):
        if ws[pr, j] > 0.0:
            nd, d1, d2 = count_distinct(ys, j, nd, d1, d2)
            if nd == 3:
                return j + 1
    return kmax + 1


@njit(cache=True, inline="always", error_model="numpy")
def count_distinct(ys, j, nd, d1, d2):
    """Count weighted point j (row of ``ys``) among the distinct points seen so far:
    ``nd`` (up to 3) of them, the first two at rows ``d1``, ``d2``; returns the
    updated (nd, d1, d2). ``ys`` holds offsets (the search) or absolute coordinates
    (`choice_cov`, rows = point indices)."""
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
def add_moments(w, yx, yy, yz, sw, sx, sy, sz, sxx, sxy, sxz, syy, syz, szz):
    """The ten moment sums about the point (sum w, sum w y, the six sums of
    w y y^T) with neighbour offset y = (yx, yy, yz) of weight w added; shared by
    `choice_cov` and `optimal_kernel` (the search), so both add in the same order."""
    return (
        sw + w,
        sx + w * yx,
        sy + w * yy,
        sz + w * yz,
        sxx + w * yx * yx,
        sxy + w * yx * yy,
        sxz + w * yx * yz,
        syy + w * yy * yy,
        syz + w * yy * yz,
        szz + w * yz * yz,
    )


@njit(cache=True, inline="always", error_model="numpy")
def cov_from_sums(sw, sx, sy, sz, sxx, sxy, sxz, syy, syz, szz, mx, my, mz):
    """Eq. 5.4 from the moments about the point itself: C = Syy - Sy m^T - m Sy^T
    + W m m^T (W = sw, Sy = (sx, sy, sz), Syy the six sums of w y y^T, m the
    unweighted mean); returns c00, c01, c02, c11, c12, c22. Shared by `choice_cov`
    and `optimal_kernel` (the search), so both form the same covariance bit for bit."""
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


@njit(cache=True, inline="always", error_model="numpy")
def choice_cov(points, idx, i, kk, ang, arow, use_normals, a, b):
    """Reason code and covariance (Eq. 5.4: c00, c01, c02, c11, c12, c22) of point i
    at one choice: its first ``kk`` neighbours, weights `cosine_sigmoid_scalar` of
    the angles in row ``arow`` of ``ang`` (all 1 without normals).

    One pass accumulating the moments about the point itself (sum w, sum w y,
    sum w y y^T) and the unweighted sum of y, from which Eq. 5.4 follows; the
    distinct weighted points are counted on absolute coordinates. Codes in order of
    precedence: bad index, non-finite, zero weights, fewer than 3 distinct points
    (covariance 0 then). `optimal_kernel` (the search) forms the same sums in the same order
    (`add_moments`) and the covariance with the same formula (`cov_from_sums`), so
    both give the same covariance bit for bit.
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
            sw, sx, sy, sz, sxx, sxy, sxz, syy, syz, szz = add_moments(
                w, yx, yy, yz, sw, sx, sy, sz, sxx, sxy, sxz, syy, syz, szz
            )
            if n_distinct < 3:
                n_distinct, first, second = count_distinct(points, m, n_distinct, first, second)
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
    c00, c01, c02, c11, c12, c22 = cov_from_sums(
        sw, sx, sy, sz, sxx, sxy, sxz, syy, syz, szz, ux / kk, uy / kk, uz / kk
    )
    return code, c00, c01, c02, c11, c12, c22
