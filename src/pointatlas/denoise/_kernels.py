"""numba kernels of the denoise room: the adaptive k search (thesis 5.4, Eq. 5.7),
the normal voting step and the point updates (docs/decisions/denoise.md).

Kernels assume validated input (finite float64 arrays, unit normals, index tables
whose rows start with the point itself and are sorted by distance) and never
validate. The 3 x 3 eigensolvers are the shared ones of
``pointatlas.normals._kernels.eig3`` (also used by the features room).
Plain-numpy references live in ``tests/denoise/reference.py``. The point-to-mesh
distance is ``pointatlas.neighbors.point_mesh_distance``, the thread rule in
``_threads.py``, the flatness step's kernel in ``_flatness.py``, the restricted quadric
update (``sharpen=True``) in ``_sharpen.py``.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from ..features._kernels.covariance import add_moments
from ..normals._kernels.eig3 import (
    eigh3_accurate,
    lanes_stage1,
    lanes_stage2,
    lanes_stage3,
)

__all__ = [
    "CLASS_CORNER",
    "CLASS_EDGE",
    "CLASS_FACE",
    "adaptive_k_kernel",
    "face_normals_kernel",
    "feature_class_kernel",
    "lonely_normals_kernel",
    "plane_lists_kernel",
    "plane_update_kernel",
    "polish_kernel",
    "table_distances_kernel",
    "voting_filter_kernel",
]

#: feature classes of the point update ([YRS+18] stage 2 as reconstructed)
CLASS_FACE = 1
CLASS_EDGE = 2
CLASS_CORNER = 3

#: neighbours per cached weight pattern of `adaptive_k_kernel` (bits of an int64,
#: sign bit unused)
MASK_BITS = 62
#: points per task of `adaptive_k_kernel` and `polish_kernel` (scratch arrays per task)
ADAPTIVE_BLOCK = 256


# --------------------------------------------------------------------------- E_dim choice


@njit(cache=True, inline="always", error_model="numpy")
def _edim_of(l1, l2, l3):
    """E_dim (Eq. 5.7, 0 ln 0 = 0) of eigenvalues l1 >= l2 >= l3 >= 0; +inf when l1 <= 0."""
    if not l1 > 0.0:
        return math.inf
    e = 0.0
    for x in ((l1 - l2) / l1, (l2 - l3) / l1, l3 / l1):
        if x > 0.0:
            e -= x * math.log(x)
    return e


@njit(parallel=True, cache=True, error_model="numpy")
def adaptive_k_kernel(points, normals, idx, k_lo, k_hi, cos_a, best_k, best_edim, masks):
    """Per point the k in [k_lo[i], k_hi[i]] of least E_dim with cut-off weights.

    Weights w_ij = 1 iff n_i . n_j >= cos_a (a = b sharp cut-off of Def. 15); the
    covariance is Eq. 5.4 (weighted outer products about the unweighted barycentre
    of the k nearest). A choice is degenerate when fewer than three neighbours carry
    weight or the eigenvalues vanish. Ties: the smallest k. ``best_k`` = -1 and
    ``best_edim`` = +inf when every choice degenerates.

    The choice depends on the normals only through the weights. ``masks[i]`` caches
    the weight pattern of point i (bit c: neighbour ``idx[i, c]`` has weight 1;
    rows with k_hi[i] > MASK_BITS are never cached): when the pattern is unchanged
    since the call that wrote it, ``best_k[i]`` and ``best_edim[i]`` from that
    call are kept, which is the same result. Callers pass -1 to force the search
    and reset the masks whenever ``points`` or ``idx`` change.

    A point's candidates are gathered first (running sums over k), then their
    eigenvalues go through the shared closed form's three stages as flat loops
    (`lanes_stage1` to `lanes_stage3`, bit for bit `eig3_fast`), which the
    compiler vectorises, as the features room's optimal-neighbourhood search does.

    Parameters
    ----------
    points : (N, 3) float64
    normals : (N, 3) float64, unit
    idx : (N, K) int64, K >= max(k_hi)
    k_lo, k_hi : (N,) int64, 1 <= k_lo <= k_hi <= K
    cos_a : float
    best_k : (N,) int64, in/out
    best_edim : (N,) float64, in/out
    masks : (N,) int64, in/out (-1: no cached pattern)
    """
    n = points.shape[0]
    width = idx.shape[1]
    nblocks = (n + ADAPTIVE_BLOCK - 1) // ADAPTIVE_BLOCK
    for blk in prange(nblocks):
        cov = np.empty((6, width))
        cand = np.empty(width, dtype=np.int64)
        st = np.empty((4, width))
        lanes = np.empty((4, width))
        for i in range(blk * ADAPTIVE_BLOCK, min(n, (blk + 1) * ADAPTIVE_BLOCK)):
            nx, ny, nz = normals[i, 0], normals[i, 1], normals[i, 2]
            kh = k_hi[i]
            if kh <= MASK_BITS:
                mask = 0
                for c in range(kh):
                    j = idx[i, c]
                    if nx * normals[j, 0] + ny * normals[j, 1] + nz * normals[j, 2] >= cos_a:
                        mask |= 1 << c
                if mask == masks[i]:
                    continue
                masks[i] = mask
            m = _gather_candidates(points, normals, idx, i, k_lo[i], kh, cos_a, cov, cand)
            for t in range(m):
                st[0, t], st[1, t], st[2, t], st[3, t] = lanes_stage1(
                    cov[0, t], cov[1, t], cov[2, t], cov[3, t], cov[4, t], cov[5, t]
                )
            for t in range(m):
                lanes[0, t], lanes[1, t], lanes[2, t], lanes[3, t] = lanes_stage2(st[3, t])
            bk = -1
            be = math.inf
            for t in range(m):
                l1, l2, l3 = lanes_stage3(
                    st[0, t],
                    st[1, t],
                    st[2, t],
                    lanes[0, t],
                    lanes[1, t],
                    lanes[2, t],
                    lanes[3, t],
                )
                e = _edim_of(l1, l2, l3)
                if e < be:
                    be = e
                    bk = cand[t]
            best_k[i] = bk
            best_edim[i] = be


@njit(cache=True, inline="always", error_model="numpy")
def _gather_candidates(points, normals, idx, i, klo, kh, cos_a, cov, cand):
    """The covariances (Eq. 5.4, cut-off weights) of point i for k = klo .. kh with
    at least three weighted neighbours, into ``cov`` (6 rows) and their k into
    ``cand``; returns their number. Running sums over k: one pass."""
    nx, ny, nz = normals[i, 0], normals[i, 1], normals[i, 2]
    px, py, pz = points[i, 0], points[i, 1], points[i, 2]
    su0 = su1 = su2 = 0.0  # unweighted sum of y = p_j - p_i
    sw = 0.0
    sy0 = sy1 = sy2 = 0.0  # weighted sum of y
    s00 = s01 = s02 = s11 = s12 = s22 = 0.0  # weighted sum of y y^T
    nw = 0
    m = 0
    for kk in range(1, kh + 1):
        j = idx[i, kk - 1]
        y0 = points[j, 0] - px
        y1 = points[j, 1] - py
        y2 = points[j, 2] - pz
        su0 += y0
        su1 += y1
        su2 += y2
        if nx * normals[j, 0] + ny * normals[j, 1] + nz * normals[j, 2] >= cos_a:
            nw += 1
            sw, sy0, sy1, sy2, s00, s01, s02, s11, s12, s22 = add_moments(
                1.0, y0, y1, y2, sw, sy0, sy1, sy2, s00, s01, s02, s11, s12, s22
            )
        if kk < klo or nw < 3:
            continue
        m0, m1, m2 = su0 / kk, su1 / kk, su2 / kk
        # sum_j w_j (y_j - m)(y_j - m)^T expanded
        cov[0, m] = s00 - 2.0 * m0 * sy0 + sw * m0 * m0
        cov[1, m] = s01 - m0 * sy1 - sy0 * m1 + sw * m0 * m1
        cov[2, m] = s02 - m0 * sy2 - sy0 * m2 + sw * m0 * m2
        cov[3, m] = s11 - 2.0 * m1 * sy1 + sw * m1 * m1
        cov[4, m] = s12 - m1 * sy2 - sy1 * m2 + sw * m1 * m2
        cov[5, m] = s22 - 2.0 * m2 * sy2 + sw * m2 * m2
        cand[m] = kk
        m += 1
    return m


# --------------------------------------------------------------------------- voting


@njit(cache=True)
def _voted_normal(t00, t01, t02, t11, t12, t22, nx, ny, nz, tau):
    """T~ n for the voting tensor T (6 entries) and normal n, not normalised.

    T~ keeps the eigenvectors whose eigenvalue is >= tau times the largest (with
    eigenvalue 1) and drops the others. Only one eigenvector is needed: the
    largest's when one eigenvalue is kept (T~ n = (v1 . n) v1), the smallest's when
    two are (T~ n = n - (v3 . n) v3); both come from the shared closed form refined
    by deflation (`eigh3_accurate`, a few ulps of lambda_1). Zero for T = 0.
    """
    l1, l2, l3, e1x, e1y, e1z, e3x, e3y, e3z = eigh3_accurate(t00, t01, t02, t11, t12, t22)
    if not l1 > 0.0:
        return 0.0, 0.0, 0.0
    if l3 / l1 >= tau:
        return nx, ny, nz
    if l2 / l1 >= tau:
        s = e3x * nx + e3y * ny + e3z * nz
        return nx - s * e3x, ny - s * e3y, nz - s * e3z
    s = e1x * nx + e1y * ny + e1z * nz
    return s * e1x, s * e1y, s * e1z


@njit(parallel=True, cache=True)
def voting_filter_kernel(normals, idx, k_of, use_cut, cos_rho, tau, out):
    """One normal voting tensor step ([YRS+18] stage 1, thesis 5.4) for every point.

    T_i = sum_j w_ij n_j n_j^T over the first ``k_of[i]`` neighbours, w_ij = 1 if
    n_i . n_j >= cos_rho else 0 (all 1 where ``use_cut[i]`` is False); eigenvalues
    scaled by the largest and set to 1 if >= tau else 0; n_i <- normalise(T~_i n_i).
    A normal whose projection vanishes is kept.

    Parameters
    ----------
    normals : (N, 3) float64, unit
    idx : (N, K) int64
    k_of : (N,) int64, 1 <= k_of <= K
    use_cut : (N,) bool
    cos_rho, tau : float
    out : (N, 3) float64, out
    """
    n = normals.shape[0]
    for i in prange(n):
        nx, ny, nz = normals[i, 0], normals[i, 1], normals[i, 2]
        t00 = t01 = t02 = t11 = t12 = t22 = 0.0
        cut = use_cut[i]
        for kk in range(k_of[i]):
            j = idx[i, kk]
            a, b, c = normals[j, 0], normals[j, 1], normals[j, 2]
            # branch-free (the cut-off is unpredictable); w 0 adds a zero: same sums
            w = 1.0 if not cut or nx * a + ny * b + nz * c >= cos_rho else 0.0
            t00 += w * (a * a)
            t01 += w * (a * b)
            t02 += w * (a * c)
            t11 += w * (b * b)
            t12 += w * (b * c)
            t22 += w * (c * c)
        x, y, z = _voted_normal(t00, t01, t02, t11, t12, t22, nx, ny, nz, tau)
        length = math.sqrt(x * x + y * y + z * z)
        if length > 1e-12:
            out[i, 0] = x / length
            out[i, 1] = y / length
            out[i, 2] = z / length
        else:
            out[i, 0], out[i, 1], out[i, 2] = nx, ny, nz


# --------------------------------------------------------------------------- point update


@njit(cache=True)
def _class_tensor(normals, idx, i, kk, tau):
    """Feature class of point i and its equal-weight voting tensor (6 entries).

    The class is the number of eigenvalues >= tau (scaled by the largest) of
    sum_j n_j n_j^T over the first ``kk`` neighbours: 1 face, 2 edge, 3 corner.
    """
    t00 = t01 = t02 = t11 = t12 = t22 = 0.0
    for c in range(kk):
        j = idx[i, c]
        a, b, cc = normals[j, 0], normals[j, 1], normals[j, 2]
        t00 += a * a
        t01 += a * b
        t02 += a * cc
        t11 += b * b
        t12 += b * cc
        t22 += cc * cc
    l1, l2, l3 = eigh3_accurate(t00, t01, t02, t11, t12, t22)[:3]
    m = 1
    if l1 > 0.0:
        if l2 / l1 >= tau:
            m += 1
        if l3 / l1 >= tau:
            m += 1
    return m, t00, t01, t02, t11, t12, t22


@njit(parallel=True, cache=True)
def feature_class_kernel(normals, idx, k_of, tau, klass):
    """[YRS+18] stage 2 as reconstructed: ``klass[i]`` = 1 face, 2 edge, 3 corner
    (eigenvalues >= tau of the equal-weight voting tensor over ``k_of[i]`` neighbours)."""
    for i in prange(normals.shape[0]):
        klass[i] = _class_tensor(normals, idx, i, k_of[i], tau)[0]


@njit(parallel=True, cache=True)
def plane_lists_kernel(normals, idx, k_of, cos_rho, lists, counts):
    """The neighbours whose planes count, per point: the first ``k_of[i]`` of row i
    of ``idx`` with n_i . n_j >= cos_rho, in table order, into ``lists[i, :counts[i]]``.

    Within a round the normals are fixed, so one call serves every update and the
    refit (`plane_update_kernel`, `face_normals_kernel`); branch-free (the cut-off
    is unpredictable, docs/decisions/denoise.md, "Speed").

    Parameters
    ----------
    normals : (N, 3) float64, unit (filtered)
    idx : (N, K) int64
    k_of : (N,) int64, <= K
    cos_rho : float
    lists : (N, K) int64, out (entries past ``counts[i]`` are scratch)
    counts : (N,) int64, out
    """
    for i in prange(normals.shape[0]):
        nx, ny, nz = normals[i, 0], normals[i, 1], normals[i, 2]
        m = 0
        for c in range(k_of[i]):
            j = idx[i, c]
            lists[i, m] = j
            m += nx * normals[j, 0] + ny * normals[j, 1] + nz * normals[j, 2] >= cos_rho
        counts[i] = m


@njit(parallel=True, cache=True)
def lonely_normals_kernel(points, normals, idx, k_of, counts, cos_rho, min_count, inv_sigma2, out):
    """Normals of points with fewer than ``min_count`` planes, replaced by their neighbours'.

    A point whose normal is within the cut-off of fewer than ``min_count`` of its
    first ``k_of[i]`` neighbours (``counts`` from `plane_lists_kernel`, the point
    itself counted) has no face to stand on: mostly a point far off the surface
    with a wild PCA normal. Its normal becomes the normalised sum of
    w_ij s_ij n_j over its other neighbours, w_ij = exp(-|p_j - p_i|^2 inv_sigma2),
    s_ij = +-1 signing n_j like n_i, when that direction is within the cut-off of
    at least ``min_count`` of the neighbours' normals (the point then has a face;
    at a clean corner or a thin edge the blend has none and n_i stays); every other
    normal is copied (docs/decisions/denoise.md, "Lonely points").

    Parameters
    ----------
    points : (N, 3) float64
    normals : (N, 3) float64, unit
    idx : (N, K) int64
    k_of, counts : (N,) int64
    cos_rho : float
    min_count : int
    inv_sigma2 : float
    out : (N, 3) float64, out (unit)
    """
    for i in prange(points.shape[0]):
        nx, ny, nz = normals[i, 0], normals[i, 1], normals[i, 2]
        out[i, 0], out[i, 1], out[i, 2] = nx, ny, nz
        if counts[i] >= min_count:
            continue
        px, py, pz = points[i, 0], points[i, 1], points[i, 2]
        sx = sy = sz = 0.0
        for c in range(1, k_of[i]):
            j = idx[i, c]
            dx, dy, dz = points[j, 0] - px, points[j, 1] - py, points[j, 2] - pz
            w = math.exp(-(dx * dx + dy * dy + dz * dz) * inv_sigma2)
            a, b, cc = normals[j, 0], normals[j, 1], normals[j, 2]
            if a * nx + b * ny + cc * nz < 0.0:
                w = -w
            sx += w * a
            sy += w * b
            sz += w * cc
        length = math.sqrt(sx * sx + sy * sy + sz * sz)
        if not length > 0.0:
            continue
        vx, vy, vz = sx / length, sy / length, sz / length
        support = 0
        for c in range(k_of[i]):
            j = idx[i, c]
            support += vx * normals[j, 0] + vy * normals[j, 1] + vz * normals[j, 2] >= cos_rho
        if support >= min_count:
            out[i, 0], out[i, 1], out[i, 2] = vx, vy, vz


@njit(parallel=True, cache=True)
def plane_update_kernel(points, normals, lists, counts, max_step, inv_sigma2, beta, out, moved2):
    """Move every point along its own normal onto its neighbours' tangent planes.

    x_i = p_i + s n_i with s minimising sum_j w_ij (m_ij . (p_i + s n_i - p_j))^2
    over the neighbours ``lists[i, :counts[i]]`` (those with n_i . n_j >= rho,
    `plane_lists_kernel`), where m_ij = (2 - beta) n_i + beta n_j and
    w_ij = exp(-|p_j - p_i|^2 inv_sigma2). beta = 1 is the symmetric form n_i + n_j
    (on a sphere or a cylinder (n_i + n_j) . (p_j - p_i) = 0 exactly, so points on
    them stay, while the one-sided n_j form, beta = 2, pushes convex parts out by
    about |p_j - p_i|^2 / 2r); beta < 1 leans on the own normal, which trades a
    slight shrinking for less of the neighbours' normal noise (later rounds,
    docs/decisions/denoise.md). |s| is clipped to ``max_step``; s = 0 when no plane
    constrains it. ``moved2[i]`` = |x_i - p_i|^2 (the automatic stop's RMS).

    Parameters
    ----------
    points : (N, 3) float64
    normals : (N, 3) float64, unit (filtered)
    lists : (N, K) int64
    counts : (N,) int64
    max_step, inv_sigma2, beta : float
    out : (N, 3) float64, out (new positions)
    moved2 : (N,) float64, out
    """
    own = 2.0 - beta
    for i in prange(points.shape[0]):
        nx, ny, nz = normals[i, 0], normals[i, 1], normals[i, 2]
        px, py, pz = points[i, 0], points[i, 1], points[i, 2]
        a = 0.0
        b = 0.0
        for c in range(counts[i]):
            j = lists[i, c]
            dx, dy, dz = points[j, 0] - px, points[j, 1] - py, points[j, 2] - pz
            w = math.exp(-(dx * dx + dy * dy + dz * dz) * inv_sigma2)
            mx = own * nx + beta * normals[j, 0]
            my = own * ny + beta * normals[j, 1]
            mz = own * nz + beta * normals[j, 2]
            g = mx * nx + my * ny + mz * nz
            a += w * g * g
            b += w * g * (mx * dx + my * dy + mz * dz)
        s = b / a if a > 0.0 else 0.0
        s = min(max(s, -max_step), max_step)
        out[i, 0] = px + s * nx
        out[i, 1] = py + s * ny
        out[i, 2] = pz + s * nz
        dx, dy, dz = out[i, 0] - px, out[i, 1] - py, out[i, 2] - pz
        moved2[i] = dx * dx + dy * dy + dz * dz


@njit(parallel=True, cache=True)
def polish_kernel(points, idx, k_normal, k_mean, lam, out):
    """One projected Laplacian step of moved points: x_i = p_i + lam ((c_i - p_i) . n_i) n_i.

    The ``k_normal`` nearest of row i of ``idx`` (the input's neighbours, the point
    itself first) by the current distances (ties by column) are selected; c_i is the
    mean of their first ``k_mean`` (the point included) and n_i the least eigenvector
    of their covariance (PCA; its sign does not matter). A covariance without a
    finite eigenvector leaves the point. The polish after a high-noise run
    (docs/decisions/denoise.md, "Polish").

    Parameters
    ----------
    points : (N, 3) float64
    idx : (N, K) int64, K >= k_normal >= k_mean >= 1
    k_normal, k_mean : int
    lam : float
    out : (N, 3) float64, out (new positions)
    """
    n = points.shape[0]
    for b in prange((n + ADAPTIVE_BLOCK - 1) // ADAPTIVE_BLOCK):
        d2 = np.empty(k_normal)
        near = np.empty(k_normal, dtype=np.int64)
        for i in range(b * ADAPTIVE_BLOCK, min(n, (b + 1) * ADAPTIVE_BLOCK)):
            _polish_point(points, idx, i, k_normal, k_mean, lam, d2, near, out)


@njit(cache=True, inline="always")
def _polish_point(points, idx, i, k_normal, k_mean, lam, d2, near, out):
    """`polish_kernel` for point i (``d2``, ``near``: scratch of k_normal entries)."""
    px, py, pz = points[i, 0], points[i, 1], points[i, 2]
    out[i, 0], out[i, 1], out[i, 2] = px, py, pz
    filled = 0
    for c in range(idx.shape[1]):  # the k_normal nearest, sorted (insertion)
        j = idx[i, c]
        dx, dy, dz = points[j, 0] - px, points[j, 1] - py, points[j, 2] - pz
        d = dx * dx + dy * dy + dz * dz
        if filled == k_normal and not d < d2[k_normal - 1]:
            continue
        m = filled if filled < k_normal else k_normal - 1
        while m > 0 and d2[m - 1] > d:
            d2[m], near[m] = d2[m - 1], near[m - 1]
            m -= 1
        d2[m], near[m] = d, j
        filled = min(filled + 1, k_normal)
    cnt = 0
    s0 = s1 = s2 = 0.0
    c00 = c01 = c02 = c11 = c12 = c22 = 0.0
    mx = my = mz = 0.0
    for r in range(k_normal):
        j = near[r]
        y0, y1, y2 = points[j, 0] - px, points[j, 1] - py, points[j, 2] - pz
        cnt, s0, s1, s2, c00, c01, c02, c11, c12, c22 = add_moments(
            1, y0, y1, y2, cnt, s0, s1, s2, c00, c01, c02, c11, c12, c22
        )
        if r < k_mean:
            mx, my, mz = mx + y0, my + y1, mz + y2
    m0, m1, m2 = s0 / cnt, s1 / cnt, s2 / cnt
    _, _, _, _, _, _, nx, ny, nz = eigh3_accurate(
        c00 / cnt - m0 * m0,
        c01 / cnt - m0 * m1,
        c02 / cnt - m0 * m2,
        c11 / cnt - m1 * m1,
        c12 / cnt - m1 * m2,
        c22 / cnt - m2 * m2,
    )
    if math.isfinite(nx) and math.isfinite(ny) and math.isfinite(nz):
        h = lam * (mx * nx + my * ny + mz * nz) / k_mean
        out[i, 0] = px + h * nx
        out[i, 1] = py + h * ny
        out[i, 2] = pz + h * nz


# --------------------------------------------------------------------------- neighbourhoods


@njit(parallel=True, cache=True)
def table_distances_kernel(points, idx, out):
    """``out[i, c]`` = |p_idx[i, c] - p_i| for a neighbour table (default neighbourhoods).

    The same arithmetic for a whole point set and for a tile of it, so the
    neighbourhood sizes k_i of `default_neighborhoods` agree bit for bit wherever
    the tables do.

    Parameters
    ----------
    points : (N, 3) float64
    idx : (N, K) int64
    out : (N, K) float64, out
    """
    for i in prange(idx.shape[0]):
        px, py, pz = points[i, 0], points[i, 1], points[i, 2]
        for c in range(idx.shape[1]):
            j = idx[i, c]
            dx = points[j, 0] - px
            dy = points[j, 1] - py
            dz = points[j, 2] - pz
            out[i, c] = math.sqrt(dx * dx + dy * dy + dz * dz)


# --------------------------------------------------------------------------- returned normals


@njit(parallel=True, cache=True)
def face_normals_kernel(points, normals, lists, counts, out):
    """PCA normal of each point's face: the neighbours that share its filtered normal.

    Over the neighbours ``lists[i, :counts[i]]`` (those with n_i . n_j >= rho, the
    planes the point update used, `plane_lists_kernel`), the eigenvector of the
    least eigenvalue of their covariance about their barycentre, signed like n_i.
    Fewer than three such neighbours, or a covariance whose two smallest
    eigenvalues coincide (no plane), keep n_i.

    Parameters
    ----------
    points : (N, 3) float64
    normals : (N, 3) float64, unit (filtered)
    lists : (N, K) int64
    counts : (N,) int64
    out : (N, 3) float64, out (unit)
    """
    for i in prange(points.shape[0]):
        nx, ny, nz = normals[i, 0], normals[i, 1], normals[i, 2]
        px, py, pz = points[i, 0], points[i, 1], points[i, 2]
        out[i, 0], out[i, 1], out[i, 2] = nx, ny, nz
        cnt = 0
        s0 = s1 = s2 = 0.0
        c00 = c01 = c02 = c11 = c12 = c22 = 0.0
        for c in range(counts[i]):
            j = lists[i, c]
            y0, y1, y2 = points[j, 0] - px, points[j, 1] - py, points[j, 2] - pz
            cnt, s0, s1, s2, c00, c01, c02, c11, c12, c22 = add_moments(
                1, y0, y1, y2, cnt, s0, s1, s2, c00, c01, c02, c11, c12, c22
            )
        if cnt < 3:
            continue
        m0, m1, m2 = s0 / cnt, s1 / cnt, s2 / cnt
        l1, l2, l3, _, _, _, vx, vy, vz = eigh3_accurate(
            c00 / cnt - m0 * m0,
            c01 / cnt - m0 * m1,
            c02 / cnt - m0 * m2,
            c11 / cnt - m1 * m1,
            c12 / cnt - m1 * m2,
            c22 / cnt - m2 * m2,
        )
        if not l2 > l3 or not (math.isfinite(vx) and math.isfinite(vy) and math.isfinite(vz)):
            continue
        if vx * nx + vy * ny + vz * nz < 0.0:
            vx, vy, vz = -vx, -vy, -vz
        out[i, 0], out[i, 1], out[i, 2] = vx, vy, vz
