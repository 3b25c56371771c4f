"""Shared constants of the features kernels: reason codes, output columns, blocking.

Conventions shared by the kernels
---------------------------------
* ``idx`` is an (N, K) int64 neighbour table sorted by distance, the point itself in
  column 0 (what `pointatlas.neighbors.query_knn` returns).
* ``ang`` is an (N, K) float64 table of angles between the point's normal and each
  neighbour's normal (angles below ``ANGLE_ZERO`` already set to 0); kernels that
  work without normals receive a (0, 0) array and ``use_normals = False``.
* Covariances are accumulated on coordinates relative to the point itself (a
  per-point origin), so far-from-origin inputs (UTM-like LAS) keep their precision.
* Points are visited in blocks of `BLOCK` (scratch arrays allocated once per
  block), in a cache-friendly order (`pointatlas._core._sort.morton_order`), rows
  `AHEAD` points later prefetched.
"""

from __future__ import annotations

from numba import njit

from ..._core._prefetch import prefetch_read, prefetch_write

# reason codes (uint8), one per point
REASON_OK = 0
REASON_NONFINITE = 1
REASON_ZERO_WEIGHTS = 2
REASON_FEW_DISTINCT = 3
REASON_ZERO_EIGENSUM = 4
#: internal: a neighbour index out of range (the caller raises)
REASON_BAD_INDEX = 255

# the 11 features, columns of the (N, N_FEATURES) matrix of `features_kernel`, in
# the order of `pointatlas.features.FEATURE_NAMES`
LINEARITY = 0
PLANARITY = 1
SCATTERING = 2
E_DIM = 3
OMNIVARIANCE = 4
ANISOTROPY = 5
CHANGE_OF_CURVATURE = 6
EIGENENTROPY = 7
EIGEN_SUM = 8
VERTICALITY = 9
FLATNESS = 10
N_FEATURES = 11

# the packed (N, N_OUT) rows of `fused_kernel` and `optimal_kernel`: one row per
# point, so the kernels' scattered writes touch 3 cache lines per point instead of 7
#: lambda_1, lambda_2, lambda_3 (descending)
OUT_EIGENVALUES = 0
#: unit eigenvector of lambda_1 (x, y, z)
OUT_VECTOR_1 = 3
#: unit eigenvector of lambda_3 (x, y, z)
OUT_VECTOR_3 = 6
#: first of the `N_FEATURES` feature columns
OUT_FEATURES = 9
N_OUT = OUT_FEATURES + N_FEATURES
#: the E_dim column of a packed row
OUT_E_DIM = OUT_FEATURES + E_DIM

#: points per parallel block (scratch arrays are allocated once per block)
BLOCK = 1024
#: how many points ahead (in visiting order) the kernels prefetch rows
AHEAD = 8


@njit(cache=True, inline="always", error_model="numpy")
def prefetch_row(arr, row):
    """Prefetch every cache line of the row ``arr[row]`` (2-D float64/int64 array)."""
    kk = arr.shape[1]
    for c in range(0, kk, 8):
        prefetch_read(arr, row, c)
    prefetch_read(arr, row, kk - 1)


@njit(cache=True, inline="always", error_model="numpy")
def prefetch_out(arr, row):
    """Prefetch the row ``arr[row]`` for writing."""
    kk = arr.shape[1]
    for c in range(0, kk, 8):
        prefetch_write(arr, row, c)
    prefetch_write(arr, row, kk - 1)
