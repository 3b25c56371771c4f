"""numba kernels of the denoise room (STYLE section 7): eigen helpers, the adaptive
k search, the normal voting step and the point updates.

Kernels assume validated input (finite float64 arrays, unit normals, index tables
whose rows start with the point itself and are sorted by distance) and never
validate. Plain-numpy references live in ``tests/denoise/reference.py``. The
point-to-mesh distance is ``pointatlas.neighbors.point_mesh_distance``, the thread
rule in ``_threads.py``.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

__all__ = [
    "CLASS_CORNER",
    "CLASS_EDGE",
    "CLASS_FACE",
    "adaptive_k_kernel",
    "feature_class_kernel",
    "plane_update_kernel",
    "quadric_update_kernel",
    "sym3_eigh",
    "sym3_eigvals",
    "voting_filter_kernel",
]

#: feature classes of the point update ([YRS+18] stage 2 as reconstructed)
CLASS_FACE = 1
CLASS_EDGE = 2
CLASS_CORNER = 3

#: neighbours per cached weight pattern of `adaptive_k_kernel` (bits of an int64,
#: sign bit unused)
MASK_BITS = 62
#: `_voted_normal` takes the closed-form eigenvector when its eigenvalue is apart
#: from the others by more than this share of the largest (error ~ 1e-16 / gap, so
#: below 1e-12); closer pairs go through Jacobi rotations
EIGEN_GAP_REL = 1e-4


# --------------------------------------------------------------------------- 3x3 eigen


@njit(cache=True)
def sym3_eigh(a, lam, vec):
    """Eigen-decomposition of a symmetric 3x3 matrix by cyclic Jacobi rotations.

    ``a`` is overwritten. Writes the eigenvalues ascending into ``lam`` (3,) and the
    unit eigenvectors as the columns of ``vec`` (3, 3), like ``numpy.linalg.eigh``.
    """
    for r in range(3):
        for s in range(3):
            vec[r, s] = 1.0 if r == s else 0.0
    scale = abs(a[0, 0]) + abs(a[1, 1]) + abs(a[2, 2]) + abs(a[0, 1]) + abs(a[0, 2]) + abs(a[1, 2])
    for _ in range(50):
        off = abs(a[0, 1]) + abs(a[0, 2]) + abs(a[1, 2])
        if off <= 1e-18 * scale or off == 0.0:
            break
        for p, q in ((0, 1), (0, 2), (1, 2)):
            apq = a[p, q]
            if apq == 0.0:
                continue
            theta = (a[q, q] - a[p, p]) / (2.0 * apq)
            t = 1.0 / (abs(theta) + math.sqrt(theta * theta + 1.0))
            if theta < 0.0:
                t = -t
            c = 1.0 / math.sqrt(t * t + 1.0)
            s_ = t * c
            for r in range(3):
                arp = a[r, p]
                arq = a[r, q]
                a[r, p] = c * arp - s_ * arq
                a[r, q] = s_ * arp + c * arq
            for r in range(3):
                apr = a[p, r]
                aqr = a[q, r]
                a[p, r] = c * apr - s_ * aqr
                a[q, r] = s_ * apr + c * aqr
            for r in range(3):
                vrp = vec[r, p]
                vrq = vec[r, q]
                vec[r, p] = c * vrp - s_ * vrq
                vec[r, q] = s_ * vrp + c * vrq
    # sort ascending (insertion sort on 3 entries), carrying the vectors
    for r in range(3):
        lam[r] = a[r, r]
    for i in range(1, 3):
        j = i
        while j > 0 and lam[j - 1] > lam[j]:
            lam[j - 1], lam[j] = lam[j], lam[j - 1]
            for r in range(3):
                vec[r, j - 1], vec[r, j] = vec[r, j], vec[r, j - 1]
            j -= 1


# --------------------------------------------------------------------------- E_dim choice


@njit(cache=True)
def sym3_eigvals(c00, c01, c02, c11, c12, c22):
    """Eigenvalues (l1 >= l2 >= l3) of a symmetric 3x3 matrix, closed form (Smith 1961)."""
    p1 = c01 * c01 + c02 * c02 + c12 * c12
    q = (c00 + c11 + c22) / 3.0
    if p1 <= 1e-300:
        a, b, c = c00, c11, c22
    else:
        d0, d1, d2 = c00 - q, c11 - q, c22 - q
        p2 = d0 * d0 + d1 * d1 + d2 * d2 + 2.0 * p1
        p = math.sqrt(p2 / 6.0)
        # det((C - q I) / p) / 2
        b00, b11, b22 = d0 / p, d1 / p, d2 / p
        b01, b02, b12 = c01 / p, c02 / p, c12 / p
        r = 0.5 * (
            b00 * (b11 * b22 - b12 * b12)
            - b01 * (b01 * b22 - b12 * b02)
            + b02 * (b01 * b12 - b11 * b02)
        )
        r = min(max(r, -1.0), 1.0)
        phi = math.acos(r) / 3.0
        a = q + 2.0 * p * math.cos(phi)
        c = q + 2.0 * p * math.cos(phi + 2.0 * math.pi / 3.0)
        b = 3.0 * q - a - c
    # sort descending
    if a < b:
        a, b = b, a
    if b < c:
        b, c = c, b
    if a < b:
        a, b = b, a
    return a, b, c


@njit(cache=True)
def _edim_from_cov(c00, c01, c02, c11, c12, c22):
    """E_dim (Eq. 5.7, 0 ln 0 = 0) of a symmetric 3x3 matrix; +inf when lambda_1 <= 0."""
    l1, l2, l3 = sym3_eigvals(c00, c01, c02, c11, c12, c22)
    l1 = max(l1, 0.0)
    l2 = max(l2, 0.0)
    l3 = max(l3, 0.0)
    if not l1 > 0.0 or not (l1 + l2 + l3) > 0.0:
        return math.inf
    e = 0.0
    for x in ((l1 - l2) / l1, (l2 - l3) / l1, l3 / l1):
        if x > 0.0:
            e -= x * math.log(x)
    return e


@njit(parallel=True, cache=True)
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
    for i in prange(n):
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
        px, py, pz = points[i, 0], points[i, 1], points[i, 2]
        su0 = su1 = su2 = 0.0  # unweighted sum of y = p_j - p_i
        sw = 0.0
        sy0 = sy1 = sy2 = 0.0  # weighted sum of y
        s00 = s01 = s02 = s11 = s12 = s22 = 0.0  # weighted sum of y y^T
        nw = 0
        bk = -1
        be = math.inf
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
                sw += 1.0
                sy0 += y0
                sy1 += y1
                sy2 += y2
                s00 += y0 * y0
                s01 += y0 * y1
                s02 += y0 * y2
                s11 += y1 * y1
                s12 += y1 * y2
                s22 += y2 * y2
            if kk < k_lo[i] or nw < 3:
                continue
            m0, m1, m2 = su0 / kk, su1 / kk, su2 / kk
            # sum_j w_j (y_j - m)(y_j - m)^T expanded
            e = _edim_from_cov(
                s00 - 2.0 * m0 * sy0 + sw * m0 * m0,
                s01 - m0 * sy1 - sy0 * m1 + sw * m0 * m1,
                s02 - m0 * sy2 - sy0 * m2 + sw * m0 * m2,
                s11 - 2.0 * m1 * sy1 + sw * m1 * m1,
                s12 - m1 * sy2 - sy1 * m2 + sw * m1 * m2,
                s22 - 2.0 * m2 * sy2 + sw * m2 * m2,
            )
            if e < be:
                be = e
                bk = kk
        best_k[i] = bk
        best_edim[i] = be


# --------------------------------------------------------------------------- voting


@njit(cache=True)
def _binarised_projector(t, tau, proj):
    """Eigen-decompose T, scale eigenvalues by the largest, keep those >= tau (set 1).

    Writes sum over kept eigenvectors of v v^T into ``proj``; returns the number of
    kept eigenvalues (0 when T is zero). ``t`` is overwritten.
    """
    lam = np.empty(3)
    vec = np.empty((3, 3))
    sym3_eigh(t, lam, vec)
    top = lam[2]
    proj[:, :] = 0.0
    if not top > 0.0:
        return 0
    kept = 0
    for e in range(3):
        if lam[e] / top >= tau:
            kept += 1
            for r in range(3):
                for s in range(3):
                    proj[r, s] += vec[r, e] * vec[s, e]
    return kept


@njit(cache=True)
def _eigenvector_of(c00, c01, c02, c11, c12, c22, lam):
    """Unit eigenvector of a symmetric 3x3 matrix for a simple eigenvalue ``lam``.

    The largest cross product of two rows of C - lam I (exact for a simple
    eigenvalue; the caller checks the gap). Returns (x, y, z).
    """
    a0, a1, a2 = c00 - lam, c01, c02
    b0, b1, b2 = c01, c11 - lam, c12
    d0, d1, d2 = c02, c12, c22 - lam
    u0, u1, u2 = a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0
    v0, v1, v2 = a1 * d2 - a2 * d1, a2 * d0 - a0 * d2, a0 * d1 - a1 * d0
    w0, w1, w2 = b1 * d2 - b2 * d1, b2 * d0 - b0 * d2, b0 * d1 - b1 * d0
    nu = u0 * u0 + u1 * u1 + u2 * u2
    nv = v0 * v0 + v1 * v1 + v2 * v2
    nw = w0 * w0 + w1 * w1 + w2 * w2
    if nv > nu and nv >= nw:
        u0, u1, u2, nu = v0, v1, v2, nv
    elif nw > nu:
        u0, u1, u2, nu = w0, w1, w2, nw
    s = 1.0 / math.sqrt(nu)
    return u0 * s, u1 * s, u2 * s


@njit(cache=True)
def _voted_normal(t00, t01, t02, t11, t12, t22, nx, ny, nz, tau):
    """T~ n for the voting tensor T (6 entries) and normal n, not normalised.

    Eigenvalues in closed form; the one eigenvector the projector needs (the
    largest's when one eigenvalue is kept, the smallest's when two are) from
    `_eigenvector_of` when it is separated from the others by more than
    EIGEN_GAP_REL of the largest, else by Jacobi rotations (`_binarised_projector`).
    """
    l1, l2, l3 = sym3_eigvals(t00, t01, t02, t11, t12, t22)
    if not l1 > 0.0:
        return 0.0, 0.0, 0.0
    kept = 1
    if l2 / l1 >= tau:
        kept += 1
    if l3 / l1 >= tau:
        kept += 1
    if kept == 3:
        return nx, ny, nz
    if kept == 1 and l1 - l2 > EIGEN_GAP_REL * l1:
        v0, v1, v2 = _eigenvector_of(t00, t01, t02, t11, t12, t22, l1)
        s = v0 * nx + v1 * ny + v2 * nz
        return s * v0, s * v1, s * v2
    if kept == 2 and l2 - l3 > EIGEN_GAP_REL * l1:
        v0, v1, v2 = _eigenvector_of(t00, t01, t02, t11, t12, t22, l3)
        s = v0 * nx + v1 * ny + v2 * nz
        return nx - s * v0, ny - s * v1, nz - s * v2
    t = np.empty((3, 3))
    t[0, 0], t[0, 1], t[0, 2] = t00, t01, t02
    t[1, 0], t[1, 1], t[1, 2] = t01, t11, t12
    t[2, 0], t[2, 1], t[2, 2] = t02, t12, t22
    proj = np.empty((3, 3))
    _binarised_projector(t, tau, proj)
    return (
        proj[0, 0] * nx + proj[0, 1] * ny + proj[0, 2] * nz,
        proj[1, 0] * nx + proj[1, 1] * ny + proj[1, 2] * nz,
        proj[2, 0] * nx + proj[2, 1] * ny + proj[2, 2] * nz,
    )


@njit(parallel=True, cache=True)
def voting_filter_kernel(normals, idx, k_of, use_cut, cos_rho, tau, out):
    """One normal voting tensor step ([YRS+18] stage 1, GUIDE C3) for every point.

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
            if cut and nx * a + ny * b + nz * c < cos_rho:
                continue
            t00 += a * a
            t01 += a * b
            t02 += a * c
            t11 += b * b
            t12 += b * c
            t22 += c * c
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
    l1, l2, l3 = sym3_eigvals(t00, t01, t02, t11, t12, t22)
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
def plane_update_kernel(points, normals, idx, k_of, cos_rho, max_step, inv_sigma2, out):
    """Move every point along its own normal onto its neighbours' tangent planes.

    x_i = p_i + s n_i with s minimising sum_j w_ij (m_ij . (p_i + s n_i - p_j))^2
    over the first ``k_of[i]`` neighbours with n_i . n_j >= cos_rho, where
    m_ij = n_i + n_j (the symmetric form: on a sphere or a cylinder
    (n_i + n_j) . (p_j - p_i) = 0 exactly, so points on them stay, while the
    one-sided n_j form pushes convex parts out by about |p_j - p_i|^2 / 2r) and
    w_ij = exp(-|p_j - p_i|^2 inv_sigma2). |s| is clipped to ``max_step``; s = 0
    when no plane constrains it.

    Parameters
    ----------
    points : (N, 3) float64
    normals : (N, 3) float64, unit (filtered)
    idx : (N, K) int64
    k_of : (N,) int64
    cos_rho, max_step, inv_sigma2 : float
    out : (N, 3) float64, out (new positions)
    """
    for i in prange(points.shape[0]):
        nx, ny, nz = normals[i, 0], normals[i, 1], normals[i, 2]
        px, py, pz = points[i, 0], points[i, 1], points[i, 2]
        a = 0.0
        b = 0.0
        for c in range(k_of[i]):
            j = idx[i, c]
            ax, ay, az = normals[j, 0], normals[j, 1], normals[j, 2]
            if nx * ax + ny * ay + nz * az < cos_rho:
                continue
            dx, dy, dz = points[j, 0] - px, points[j, 1] - py, points[j, 2] - pz
            w = math.exp(-(dx * dx + dy * dy + dz * dz) * inv_sigma2)
            mx, my, mz = nx + ax, ny + ay, nz + az
            g = mx * nx + my * ny + mz * nz
            a += w * g * g
            b += w * g * (mx * dx + my * dy + mz * dz)
        s = b / a if a > 0.0 else 0.0
        s = min(max(s, -max_step), max_step)
        out[i, 0] = px + s * nx
        out[i, 1] = py + s * ny
        out[i, 2] = pz + s * nz


@njit(parallel=True, cache=True)
def quadric_update_kernel(points, normals, idx, k_of, cos_rho, tau, max_step, sharpen, out, klass):
    """Restricted quadric point update ([YRS+18] stages 2-3 as reconstructed).

    Stage 2: ``klass[i]`` as in `feature_class_kernel`. Stage 3 (``sharpen``; else
    every point is treated as a face point, moving along its own normal only): p_i
    moves by x = D s, D = n_i (face) or the dominant eigenvectors (edge: two;
    corner: all), minimising sum_j w_j (n_j . (p_i + x - p_j))^2 with
    w_j = [n_i . n_j >= cos_rho] for faces and w_j = [|n_j . d_q| >= cos_rho for a
    dominant d_q] otherwise (a bevel normal, e.g. the bisector at a mesh edge,
    casts no plane); the solve drops directions whose eigenvalue is below 1e-6 of
    the largest, and |x| is clipped to ``max_step``.

    Parameters
    ----------
    points : (N, 3) float64
    normals : (N, 3) float64, unit (filtered)
    idx : (N, K) int64
    k_of : (N,) int64
    cos_rho, tau, max_step : float
    sharpen : bool
    out : (N, 3) float64, out (new positions)
    klass : (N,) int64, out
    """
    n = points.shape[0]
    for i in prange(n):
        kk = k_of[i]
        m, t00, t01, t02, t11, t12, t22 = _class_tensor(normals, idx, i, kk, tau)
        klass[i] = m
        if sharpen and m > 1:
            x0, x1, x2 = _feature_move(points, normals, idx, i, kk, m, cos_rho,
                                       t00, t01, t02, t11, t12, t22)  # fmt: skip
        else:
            x0, x1, x2 = _normal_move(points, normals, idx, i, kk, cos_rho)
        length = math.sqrt(x0 * x0 + x1 * x1 + x2 * x2)
        scale = 1.0
        if length > max_step:
            scale = max_step / length
        out[i, 0] = points[i, 0] + scale * x0
        out[i, 1] = points[i, 1] + scale * x1
        out[i, 2] = points[i, 2] + scale * x2


@njit(cache=True)
def _normal_move(points, normals, idx, i, kk, cos_rho):
    """Face move x = s n_i minimising sum_j (n_j . (p_i + s n_i - p_j))^2 over the
    first ``kk`` neighbours with n_i . n_j >= cos_rho (zero when no plane constrains s).
    """
    nx, ny, nz = normals[i, 0], normals[i, 1], normals[i, 2]
    a = 0.0
    b = 0.0
    for c in range(kk):
        j = idx[i, c]
        g = nx * normals[j, 0] + ny * normals[j, 1] + nz * normals[j, 2]
        if g < cos_rho:
            continue
        off = (
            normals[j, 0] * (points[i, 0] - points[j, 0])
            + normals[j, 1] * (points[i, 1] - points[j, 1])
            + normals[j, 2] * (points[i, 2] - points[j, 2])
        )
        a += g * g
        b -= g * off
    s = b / a if a > 0.0 else 0.0
    return s * nx, s * ny, s * nz


@njit(cache=True)
def _feature_move(points, normals, idx, i, kk, m, cos_rho, t00, t01, t02, t11, t12, t22):
    """Edge/corner move x = D s, D the m dominant eigenvectors of the voting tensor T.

    Minimises sum_j (n_j . (p_i + x - p_j))^2 over neighbours whose normal is within
    arccos(cos_rho) of a dominant direction (up to sign); the solve drops directions
    whose eigenvalue is below 1e-6 of the largest.
    """
    t = np.empty((3, 3))
    t[0, 0], t[0, 1], t[0, 2] = t00, t01, t02
    t[1, 0], t[1, 1], t[1, 2] = t01, t11, t12
    t[2, 0], t[2, 1], t[2, 2] = t02, t12, t22
    lam = np.empty(3)
    vec = np.empty((3, 3))
    sym3_eigh(t, lam, vec)
    d = np.empty((3, m))
    for c in range(m):
        for r in range(3):
            d[r, c] = vec[r, 2 - c]
    a = np.zeros((m, m))
    b = np.zeros(m)
    g = np.zeros(m)
    for c in range(kk):
        j = idx[i, c]
        aligned = False
        for q in range(m):
            g[q] = d[0, q] * normals[j, 0] + d[1, q] * normals[j, 1] + d[2, q] * normals[j, 2]
            if abs(g[q]) >= cos_rho:
                aligned = True
        if not aligned:
            continue
        off = 0.0
        for r in range(3):
            off += normals[j, r] * (points[i, r] - points[j, r])
        for q in range(m):
            b[q] -= g[q] * off
            for s in range(m):
                a[q, s] += g[q] * g[s]
    a3 = np.zeros((3, 3))
    for q in range(m):
        for s in range(m):
            a3[q, s] = a[q, s]
    mu3 = np.empty(3)
    w3 = np.empty((3, 3))
    sym3_eigh(a3, mu3, w3)
    # the m x m block's eigenpairs are the last m of the padded 3 x 3 (zeros first)
    mu = mu3[3 - m :]
    w = w3[:m, 3 - m :]
    s_vec = np.zeros(m)
    if mu[m - 1] > 0.0:
        for e in range(m):
            if mu[e] > 1e-6 * mu[m - 1]:
                proj = 0.0
                for q in range(m):
                    proj += w[q, e] * b[q]
                for q in range(m):
                    s_vec[q] += w[q, e] * proj / mu[e]
    x0 = 0.0
    x1 = 0.0
    x2 = 0.0
    for q in range(m):
        x0 += d[0, q] * s_vec[q]
        x1 += d[1, q] * s_vec[q]
        x2 += d[2, q] * s_vec[q]
    return x0, x1, x2
