"""numba kernels of ``sharpen=True``: [YRS+18]'s restricted quadric point update as
reconstructed (docs/decisions/denoise.md, "sharpen=True").

Kernels assume validated input and never validate; the plain-numpy reference is
``tests/denoise/reference.py`` (``quadric_update``).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from ..normals._kernels.eig3 import eig3_jacobi
from ._kernels import _class_tensor

__all__ = ["quadric_update_kernel"]


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
            x0, x1, x2 = _feature_move(
                points, normals, idx, i, kk, m, cos_rho, t00, t01, t02, t11, t12, t22
            )
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
    scratch = np.empty((3, 3))
    lam = np.empty(3)
    vec = np.empty((3, 3))
    eig3_jacobi(t, scratch, lam, vec)  # descending
    d = np.empty((3, m))
    for c in range(m):
        for r in range(3):
            d[r, c] = vec[r, c]
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
    mu = np.empty(3)
    w = np.empty((3, 3))
    eig3_jacobi(a3, scratch, mu, w)  # descending
    # the zero padding stays exact (Jacobi never rotates a zero row), so the padded
    # directions carry eigenvalue 0 and are dropped below
    s_vec = np.zeros(m)
    if mu[0] > 0.0:
        for e in range(3):
            if mu[e] > 1e-6 * mu[0]:
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
