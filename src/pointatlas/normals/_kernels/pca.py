"""PCA normals of k-neighbourhoods (numba; validated input assumed).

Plain-numpy reference: ``tests/normals/reference.py``.
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from .eig3 import sym3_eigen_scalars

__all__ = ["pca_normals_kernel"]

#: points per parallel block (work arrays are allocated per block)
_BLOCK = 512


@njit(cache=True, parallel=True)
def pca_normals_kernel(points, indices, k, degenerate_ratio, normals, eigenvalues, degenerate):
    """PCA normal of every point from its first ``k`` neighbours (in ``indices``).

    Parameters
    ----------
    points : ndarray of shape (N, 3), float64
    indices : ndarray of shape (N, m), int64, m >= k
        Neighbour indices (column 0 is usually the point itself).
    k : int
        Number of columns used.
    degenerate_ratio : float
        lambda_2 <= degenerate_ratio * lambda_1 flags the neighbourhood.
    normals : ndarray of shape (N, 3), float64
        Output: unit eigenvector of the smallest eigenvalue; (0, 0, 1) when all
        neighbours coincide; a unit vector orthogonal to the line when collinear.
    eigenvalues : ndarray of shape (N, 3), float64
        Output: covariance eigenvalues, descending, clipped at 0.
    degenerate : ndarray of shape (N,), bool
        Output: the plane is undefined (coincident or collinear neighbours).

    Notes
    -----
    Covariance about the neighbourhood mean, computed on coordinates relative to
    the point itself (differences of nearby points are exact, so UTM-sized
    offsets lose no precision), divided by k.
    """
    n = indices.shape[0]
    n_blocks = (n + _BLOCK - 1) // _BLOCK
    for b in prange(n_blocks):
        stop = min(n, (b + 1) * _BLOCK)
        for i in range(b * _BLOCK, stop):
            px = points[i, 0]
            py = points[i, 1]
            pz = points[i, 2]
            mx = 0.0
            my = 0.0
            mz = 0.0
            for j in range(k):
                q = indices[i, j]
                mx += points[q, 0] - px
                my += points[q, 1] - py
                mz += points[q, 2] - pz
            mx /= k
            my /= k
            mz /= k
            cxx = 0.0
            cxy = 0.0
            cxz = 0.0
            cyy = 0.0
            cyz = 0.0
            czz = 0.0
            for j in range(k):
                q = indices[i, j]
                dx = points[q, 0] - px - mx
                dy = points[q, 1] - py - my
                dz = points[q, 2] - pz - mz
                cxx += dx * dx
                cxy += dx * dy
                cxz += dx * dz
                cyy += dy * dy
                cyz += dy * dz
                czz += dz * dz
            w0, w1, w2, u0, u1, u2, v0, v1, v2 = sym3_eigen_scalars(
                cxx / k, cxy / k, cxz / k, cyy / k, cyz / k, czz / k
            )
            eigenvalues[i, 0] = max(w0, 0.0)
            eigenvalues[i, 1] = max(w1, 0.0)
            eigenvalues[i, 2] = max(w2, 0.0)
            l1 = eigenvalues[i, 0]
            is_deg = eigenvalues[i, 1] <= degenerate_ratio * l1
            degenerate[i] = is_deg
            if l1 == 0.0:
                # all neighbours coincide: no direction at all; documented fallback
                normals[i, 0] = 0.0
                normals[i, 1] = 0.0
                normals[i, 2] = 1.0
                continue
            if is_deg:
                # collinear: any direction orthogonal to the line; take the one
                # orthogonal to the line and to the coordinate axis least aligned
                # with it (deterministic, independent of Jacobi's choice)
                ux, uy, uz = u0, u1, u2
                ax, ay, az = abs(ux), abs(uy), abs(uz)
                if ax <= ay and ax <= az:
                    nx, ny, nz = 0.0, -uz, uy  # e_x x u
                elif ay <= az:
                    nx, ny, nz = uz, 0.0, -ux  # e_y x u
                else:
                    nx, ny, nz = -uy, ux, 0.0  # e_z x u
            else:
                nx, ny, nz = v0, v1, v2
            norm = np.sqrt(nx * nx + ny * ny + nz * nz)
            normals[i, 0] = nx / norm
            normals[i, 1] = ny / norm
            normals[i, 2] = nz / norm
