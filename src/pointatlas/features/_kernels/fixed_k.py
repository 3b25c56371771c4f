"""The fixed-k kernels: one (a, b, k) choice per point, and the batch helpers behind
`weighted_covariances`, `symmetric_eigenvalues`, `eigen_features` and
`normal_angles` (numba; validated input assumed).

Plain-numpy references: ``tests/features/reference.py``.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from ..._core._prefetch import prefetch_read
from ...normals._kernels.eig3 import eig3_jacobi
from .covariance import choice_cov
from .formulas import eigen_features_row, write_features
from .layout import (
    AHEAD,
    BLOCK,
    N_FEATURES,
    N_OUT,
    REASON_OK,
    REASON_ZERO_EIGENSUM,
    prefetch_out,
    prefetch_row,
)
from .math_helpers import normal_angle

__all__ = [
    "angles_kernel",
    "eigvals_batch_kernel",
    "features_kernel",
    "fused_kernel",
    "unit_normals_kernel",
]


@njit(parallel=True, cache=True, error_model="numpy")
def eigvals_batch_kernel(mats, out):
    """Eigenvalues (descending, not clipped) of symmetric (N, 3, 3) ``mats`` into (N, 3)."""
    n = mats.shape[0]
    nblocks = (n + BLOCK - 1) // BLOCK
    for blk in prange(nblocks):
        a = np.empty((3, 3))
        v = np.empty((3, 3))
        lam = np.empty(3)
        vec = np.empty((3, 3))
        for i in range(blk * BLOCK, min(n, (blk + 1) * BLOCK)):
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
    """Angle between each point's normal and its neighbours' (`normal_angle`).

    Rows are visited in ``order`` (a permutation; see `pointatlas._core._sort.morton_order`) in
    blocks, the index and output rows `AHEAD` points later prefetched.
    """
    n, kk = idx.shape
    nblocks = (n + BLOCK - 1) // BLOCK
    for blk in prange(nblocks):
        t_end = min(n, (blk + 1) * BLOCK)
        for t in range(blk * BLOCK, t_end):
            if t + AHEAD < t_end:
                ia = order[t + AHEAD]
                prefetch_row(idx, ia)
                prefetch_out(out, ia)
                prefetch_read(normals, ia, 0)
            i = order[t]
            nx = normals[i, 0]
            ny = normals[i, 1]
            nz = normals[i, 2]
            for j in range(kk):
                m = idx[i, j]
                out[i, j] = normal_angle(nx, ny, nz, normals[m, 0], normals[m, 1], normals[m, 2])


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
def features_kernel(eig, vec3, reason, m1, m2, out):
    """Per-point features from eigenvalues into ``out`` (N, `N_FEATURES`); NaN where
    reason != 0. Columns as named in `layout` (`write_features`); verticality from
    ``vec3`` (zeros give 1)."""
    n = eig.shape[0]
    for i in prange(n):
        if reason[i] != REASON_OK:
            for c in range(N_FEATURES):
                out[i, c] = np.nan
            continue
        write_features(out, i, 0, eig[i, 0], eig[i, 1], eig[i, 2], vec3[i, 2], m1, m2, False)


@njit(parallel=True, cache=True, error_model="numpy")
def fused_kernel(points, idx, order, k_of, ang, use_normals, a_of, b_of, m1, m2, out, reason):
    """One (a, b, k) choice per point: covariance, eigen-decomposition and features.

    Single pass over the neighbours accumulating the moments about the point itself
    (sum w, sum w y, sum w y y^T) and the unweighted sum of y; Eq. 5.4 follows
    from them. Eigenvalues and vectors by `eigh3_accurate`; features by
    `write_features` (`eigen_features_row`). Row i of ``out`` (N, `N_OUT`)
    receives the eigenvalues, eigenvector_1, eigenvector_3 and the features of
    point i (columns named in `layout`); degenerate rows are NaN. Points are
    visited in ``order`` (see `pointatlas._core._sort.morton_order`) in blocks:
    first the covariances of the block (the index-table and output rows of the
    point `AHEAD` places later and the neighbour coordinates of the point
    `AHEAD` / 2 places later prefetched), then the eigen-decompositions and
    features, a loop without memory gathers whose iterations overlap. ``k_of``,
    ``a_of`` and ``b_of`` have one entry per point or a single entry for all. A
    neighbour index outside [0, N) gives reason `REASON_BAD_INDEX` (the caller
    raises).
    """
    n = idx.shape[0]
    n_pts = points.shape[0]
    per_k = k_of.shape[0] > 1
    per_ab = a_of.shape[0] > 1
    nblocks = (n + BLOCK - 1) // BLOCK
    for blk in prange(nblocks):
        t0 = blk * BLOCK
        t_end = min(n, t0 + BLOCK)
        # per block: the six entries c00, c01, c02, c11, c12, c22 of each covariance
        # and its reason code
        block_cov = np.empty((BLOCK, 6))
        block_reason = np.empty(BLOCK, dtype=np.uint8)
        for t in range(t0, t_end):
            if t + AHEAD < t_end:
                ia = order[t + AHEAD]
                prefetch_row(idx, ia)
                if use_normals:
                    prefetch_row(ang, ia)
                prefetch_out(out, ia)
            if t + AHEAD // 2 < t_end:
                ib = order[t + AHEAD // 2]
                for j in range(k_of[ib] if per_k else k_of[0]):
                    mb = idx[ib, j]
                    if 0 <= mb < n_pts:
                        prefetch_read(points, mb, 0)
            i = order[t]
            kk = k_of[i] if per_k else k_of[0]
            a = a_of[i] if per_ab else a_of[0]
            b = b_of[i] if per_ab else b_of[0]
            r = t - t0
            code, c00, c01, c02, c11, c12, c22 = choice_cov(
                points, idx, i, kk, ang, i, use_normals, a, b
            )
            block_cov[r, 0] = c00
            block_cov[r, 1] = c01
            block_cov[r, 2] = c02
            block_cov[r, 3] = c11
            block_cov[r, 4] = c12
            block_cov[r, 5] = c22
            block_reason[r] = code
        for t in range(t0, t_end):
            i = order[t]
            r = t - t0
            code = block_reason[r]
            if code == REASON_OK and not eigen_features_row(
                out,
                i,
                block_cov[r, 0],
                block_cov[r, 1],
                block_cov[r, 2],
                block_cov[r, 3],
                block_cov[r, 4],
                block_cov[r, 5],
                m1,
                m2,
            ):
                code = REASON_ZERO_EIGENSUM
            reason[i] = code
            if code != REASON_OK:
                for c in range(N_OUT):
                    out[i, c] = np.nan
