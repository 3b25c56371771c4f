"""The symmetric 3 x 3 eigensolvers of pointatlas, in one place (numba).

Shared by the normals room (`sym3_eigen`: PCA normals) and the features room
(`eig3_jacobi`: `symmetric_eigenvalues`; `eig3_fast` and its branch-free stages:
the optimal-neighbourhood search; `eigh3_accurate`: the features of a chosen
neighbourhood). Validated input assumed.

Which solver where
------------------
* Cyclic Jacobi (`_rotate`, `_jacobi_sweeps`, `_descending`): accurate vectors for
  close and tiny eigenvalues. `sym3_eigen` scales the matrix by its largest entry
  first and allows 30 sweeps; `eig3_jacobi` works on the matrix as given and
  allows 12. Both stop as soon as a sweep rotates nothing (3-6 sweeps for a
  3 x 3), so the caps only bound pathological input; they differ because the
  two rooms' results are frozen as they are.
* Closed form without trigonometric calls (`eig3_fast`, stages `lanes_stage1`
  to `lanes_stage3`): eigenvalues only, about 1e-8 lambda_1 on double roots;
  the search ranks ~100 candidates per point with it.
* Closed form refined by deflation (`eigh3_accurate`): eigenvalues to a few ulps
  of lambda_1 and the eigenvectors of lambda_1 and lambda_3.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

__all__ = [
    "eig3_fast",
    "eig3_jacobi",
    "eig3_lanes",
    "eigh3_accurate",
    "lanes_stage1",
    "lanes_stage2",
    "lanes_stage3",
    "sym3_eigen",
    "sym3_eigen_scalars",
]

_EPS = np.finfo(np.float64).eps
#: sweep caps of the two Jacobi solvers (see the module notes)
_PCA_MAX_SWEEPS = 30
_FEATURES_MAX_SWEEPS = 12


# --------------------------------------------------------------------------- Jacobi


@njit(cache=True)
def _rotate(a, v, p, q):
    """One Jacobi rotation zeroing a[p, q] of the symmetric 3 x 3 matrix ``a``.

    Rutishauser's formulas (`_rotate_scalars`, on the entries it changes); ``v``
    accumulates the rotations (columns = vectors). Returns False when a[p, q] is
    already negligible, relative to the diagonal (Demmel-Veselic criterion, which
    keeps small eigenvalues relatively accurate).
    """
    r = 3 - p - q  # the third index
    changed, app, aqq, apq, arp, arq, vp0, vp1, vp2, vq0, vq1, vq2 = _rotate_scalars(
        a[p, p],
        a[q, q],
        a[p, q],
        a[r, p],
        a[r, q],
        v[0, p],
        v[1, p],
        v[2, p],
        v[0, q],
        v[1, q],
        v[2, q],
    )
    a[p, q] = apq  # 0 when negligible (unchanged when already 0)
    a[q, p] = apq
    if not changed:
        return False
    a[p, p] = app
    a[q, q] = aqq
    a[r, p] = arp
    a[p, r] = arp
    a[r, q] = arq
    a[q, r] = arq
    v[0, p], v[1, p], v[2, p] = vp0, vp1, vp2
    v[0, q], v[1, q], v[2, q] = vq0, vq1, vq2
    return True


@njit(cache=True)
def _jacobi_sweeps(a, v, max_sweeps):
    """Cyclic Jacobi sweeps (pairs (0, 1), (0, 2), (1, 2)) on the symmetric ``a``
    until a sweep rotates nothing or ``max_sweeps`` are done; ``v`` accumulates
    the rotations."""
    for _ in range(max_sweeps):
        changed = _rotate(a, v, 0, 1)
        changed = _rotate(a, v, 0, 2) or changed
        changed = _rotate(a, v, 1, 2) or changed
        if not changed:
            break


@njit(cache=True, inline="always")
def _descending(d0, d1, d2):
    """Indices of d0, d1, d2 in descending order, stable (ties: lower index first)."""
    i0, i1, i2 = 0, 1, 2
    if d1 > d0:
        i0, i1 = 1, 0
    dd = (d0, d1, d2)
    if d2 > dd[i1]:
        if d2 > dd[i0]:
            i0, i1, i2 = 2, i0, i1
        else:
            i1, i2 = 2, i1
    return i0, i1, i2


@njit(cache=True, inline="always")
def _rotate_scalars(app, aqq, apq, arp, arq, vp0, vp1, vp2, vq0, vq1, vq2):
    """`_rotate` on scalars: one Jacobi rotation zeroing a_pq, the same operations in
    the same order (so the same bits) with the matrix and vectors in registers.

    ``app``, ``aqq``, ``apq`` the pivot entries, ``arp``, ``arq`` the entries of the
    third row r; ``vp*``, ``vq*`` columns p and q of the vectors. Returns the
    changed flag and the eleven updated values (a_pq then 0 when negligible).
    """
    if apq == 0.0:
        return False, app, aqq, apq, arp, arq, vp0, vp1, vp2, vq0, vq1, vq2
    if abs(apq) <= _EPS * np.sqrt(abs(app * aqq)) or abs(apq) < 1e-300:
        return False, app, aqq, 0.0, arp, arq, vp0, vp1, vp2, vq0, vq1, vq2
    theta = (aqq - app) / (2.0 * apq)
    if abs(theta) > 1e150:
        t = 0.5 / theta
    else:
        t = 1.0 / (abs(theta) + np.sqrt(theta * theta + 1.0))
        if theta < 0.0:
            t = -t
    c = 1.0 / np.sqrt(t * t + 1.0)
    s = t * c
    return (
        True,
        app - t * apq,
        aqq + t * apq,
        0.0,
        c * arp - s * arq,
        s * arp + c * arq,
        c * vp0 - s * vq0,
        c * vp1 - s * vq1,
        c * vp2 - s * vq2,
        s * vp0 + c * vq0,
        s * vp1 + c * vq1,
        s * vp2 + c * vq2,
    )


@njit(cache=True, inline="always")
def sym3_eigen_scalars(a00, a01, a02, a11, a12, a22):
    """`sym3_eigen` of the symmetric matrix given by its upper triangle, in registers.

    Returns ``(w0, w1, w2, u0, u1, u2, n0, n1, n2)``: the eigenvalues in descending
    order, the eigenvector u of w0 and n of w2. The same cyclic Jacobi sweeps as
    `sym3_eigen` (scaled by the largest entry, Rutishauser's rotations, pairs (0, 1),
    (0, 2), (1, 2), at most 30 sweeps), the same operations in the same order: the
    same bits, about twice as fast (no 3 x 3 arrays in memory).
    """
    scale = 0.0
    for x in (a00, a01, a02, a11, a12, a22):  # as `sym3_eigen`'s loop
        if abs(x) > scale:
            scale = abs(x)
    if scale == 0.0:
        return 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0
    a00 /= scale
    a01 /= scale
    a02 /= scale
    a11 /= scale
    a12 /= scale
    a22 /= scale
    # vectors as columns: c0 = (v00, v10, v20), c1 = (v01, v11, v21), c2 = (v02, v12, v22)
    v00, v10, v20 = 1.0, 0.0, 0.0
    v01, v11, v21 = 0.0, 1.0, 0.0
    v02, v12, v22 = 0.0, 0.0, 1.0
    for _ in range(_PCA_MAX_SWEEPS):
        ch0, a00, a11, a01, a02, a12, v00, v10, v20, v01, v11, v21 = _rotate_scalars(
            a00, a11, a01, a02, a12, v00, v10, v20, v01, v11, v21
        )
        ch1, a00, a22, a02, a01, a12, v00, v10, v20, v02, v12, v22 = _rotate_scalars(
            a00, a22, a02, a01, a12, v00, v10, v20, v02, v12, v22
        )
        ch2, a11, a22, a12, a01, a02, v01, v11, v21, v02, v12, v22 = _rotate_scalars(
            a11, a22, a12, a01, a02, v01, v11, v21, v02, v12, v22
        )
        if not (ch0 or ch1 or ch2):
            break
    i0, i1, i2 = _descending(a00, a11, a22)
    d = (a00, a11, a22)
    c0 = (v00, v10, v20)
    c1 = (v01, v11, v21)
    c2 = (v02, v12, v22)
    u = c0 if i0 == 0 else (c1 if i0 == 1 else c2)
    nv = c0 if i2 == 0 else (c1 if i2 == 1 else c2)
    return (d[i0] * scale, d[i1] * scale, d[i2] * scale, u[0], u[1], u[2], nv[0], nv[1], nv[2])


@njit(cache=True)
def sym3_eigen(a, v, w):
    """Eigen-decomposition of a symmetric 3 x 3 matrix by cyclic Jacobi sweeps.

    Parameters
    ----------
    a : ndarray of shape (3, 3), float64
        Symmetric input; overwritten (ends diagonal).
    v : ndarray of shape (3, 3), float64
        Output: eigenvectors as columns, matching ``w``.
    w : ndarray of shape (3,), float64
        Output: eigenvalues in descending order.

    Notes
    -----
    The matrix is scaled by its largest absolute entry first (no over/underflow).
    Jacobi keeps eigenvectors accurate for close and tiny eigenvalues, which the
    closed-form (trigonometric) solution does not. A zero matrix gives zero
    eigenvalues and the identity.
    """
    scale = 0.0
    for i in range(3):
        for j in range(3):
            if abs(a[i, j]) > scale:
                scale = abs(a[i, j])
    for i in range(3):
        for j in range(3):
            v[i, j] = 1.0 if i == j else 0.0
    if scale == 0.0:
        w[0] = 0.0
        w[1] = 0.0
        w[2] = 0.0
        return
    for i in range(3):
        for j in range(3):
            a[i, j] /= scale
    _jacobi_sweeps(a, v, _PCA_MAX_SWEEPS)
    i0, i1, i2 = _descending(a[0, 0], a[1, 1], a[2, 2])
    d0, d1, d2 = a[i0, i0], a[i1, i1], a[i2, i2]
    for m in range(3):
        x0, x1, x2 = v[m, i0], v[m, i1], v[m, i2]
        v[m, 0] = x0
        v[m, 1] = x1
        v[m, 2] = x2
    w[0] = d0 * scale
    w[1] = d1 * scale
    w[2] = d2 * scale


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
    _jacobi_sweeps(a, v, _FEATURES_MAX_SWEEPS)
    dd = (a[0, 0], a[1, 1], a[2, 2])
    order = _descending(dd[0], dd[1], dd[2])
    for r in range(3):
        lam[r] = dd[order[r]]
        for m in range(3):
            vec[m, r] = v[m, order[r]]


# --------------------------------------------------------------------------- closed form

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
    faster than acos + 2 cos and as accurate (double roots resolved to
    ~1e-8 lambda_1; `eigh3_accurate` refines). Four divisions and three square
    roots. The same arithmetic as the stages `lanes_stage1` to `lanes_stage3`
    that the optimal-neighbourhood search runs, so both give the same values bit
    for bit.
    """
    q, p, p2, r = lanes_stage1(c00, c01, c02, c11, c12, c22)
    if p2 <= 0.0:
        v = max(q, 0.0)
        return v, v, v
    v1, h1, v3, h3 = lanes_stage2(r)
    return lanes_stage3(q, p, p2, v1, h1, v3, h3)


@njit(cache=True, inline="always", error_model="numpy")
def eig3_lanes(c00, c01, c02, c11, c12, c22):
    """`eig3_fast` without branches (selects only), bit for bit the same values.

    Composed of three stages (`lanes_stage1`, `lanes_stage2`, `lanes_stage3`)
    that the optimal-neighbourhood search (``features/_kernels/optimal.py``) runs
    as three flat loops over its candidates: each loop vectorises, and its
    iterations are independent, so the long chain of square roots and divisions
    of one candidate overlaps with the next ones.
    """
    q, p, p2, r = lanes_stage1(c00, c01, c02, c11, c12, c22)
    v1, h1, v3, h3 = lanes_stage2(r)
    return lanes_stage3(q, p, p2, v1, h1, v3, h3)


@njit(cache=True, inline="always", error_model="numpy")
def lanes_stage1(c00, c01, c02, c11, c12, c22):
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
def lanes_stage2(r):
    """v1 = sqrt(1 + r), v3 = sqrt(1 - r) and the first Newton iterates h1, h3."""
    v1 = math.sqrt(1.0 + r)
    v3 = math.sqrt(1.0 - r)
    h1, h3 = _ct_newton2(v1, _ct_start(v1), v3, _ct_start(v3))
    return v1, h1, v3, h3


@njit(cache=True, inline="always", error_model="numpy")
def lanes_stage3(q, p, p2, v1, h1, v3, h3):
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


@njit(cache=True, inline="always", error_model="numpy")
def _sym_mul(c00, c01, c02, c11, c12, c22, x, y, z):
    """C (x, y, z) for the symmetric C given by its upper triangle."""
    return (
        c00 * x + c01 * y + c02 * z,
        c01 * x + c11 * y + c12 * z,
        c02 * x + c12 * y + c22 * z,
    )


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
    cvx, cvy, cvz = _sym_mul(c00, c01, c02, c11, c12, c22, vx, vy, vz)
    cux, cuy, cuz = _sym_mul(c00, c01, c02, c11, c12, c22, ux, uy, uz)
    cwx, cwy, cwz = _sym_mul(c00, c01, c02, c11, c12, c22, wx, wy, wz)
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
