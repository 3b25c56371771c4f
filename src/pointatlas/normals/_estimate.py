"""PCA normal estimation (unoriented) on k-nearest neighbourhoods."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .._core import as_k, as_points, check_neighbors, readonly, readonly_view
from .._core.tolerances import NORMAL_DEGENERATE_RATIO
from ..neighbors import query_knn
from ._kernels import pca_normals_kernel

__all__ = ["PCANormalsResult", "estimate_normals", "pca_normals"]


def _neighbor_indices(points: np.ndarray, k: int, neighbors) -> np.ndarray:
    """The first k columns of validated neighbour indices, or one `query_knn` call.

    ``neighbors`` may be an index array of shape (N, m >= k) or the
    ``(indices, distances)`` tuple returned by `query_knn`; k validated (`as_k`).
    """
    if neighbors is None:
        return query_knn(points, k)[0]
    return check_neighbors(neighbors, points.shape[0], k=k)


@dataclass(frozen=True, slots=True)
class PCANormalsResult:
    """Unoriented PCA normals with their covariance eigenvalues.

    Attributes
    ----------
    normals : ndarray of shape (N, 3), float64
        Unit eigenvectors of the smallest covariance eigenvalue (arbitrary sign).
    eigenvalues : ndarray of shape (N, 3), float64
        Covariance eigenvalues lambda_1 >= lambda_2 >= lambda_3 >= 0.
    is_degenerate : ndarray of shape (N,), bool
        True where the tangent plane is undefined (all neighbours coincide or are
        collinear: lambda_2 <= 1e-10 lambda_1); ``normals`` holds the documented
        fallback there.
    """

    normals: np.ndarray
    eigenvalues: np.ndarray
    is_degenerate: np.ndarray

    def __post_init__(self):
        for name in ("normals", "eigenvalues", "is_degenerate"):
            readonly(getattr(self, name))

    @property
    def n_degenerate(self) -> int:
        """Number of degenerate neighbourhoods."""
        return int(np.count_nonzero(self.is_degenerate))


def pca_normals(points, k: int = 20, *, neighbors=None) -> PCANormalsResult:
    """PCA normals, covariance eigenvalues and degeneracy flags of every point.

    Parameters
    ----------
    points : array_like of shape (N, 3)
        Coordinates (float64 after conversion, finite).
    k : int
        Neighbourhood size, the point itself included (3 <= k <= N).
    neighbors : ndarray of shape (N, m), int, or tuple, optional
        Precomputed neighbour indices with m >= k (for example
        ``query_knn(points, 20)[0]``, or the tuple `query_knn` returns); the first
        k columns are used. Default: one call ``query_knn(points, k)``.

    Returns
    -------
    result : PCANormalsResult
        ``normals`` (N, 3) unit with arbitrary sign, ``eigenvalues`` (N, 3)
        descending, ``is_degenerate`` (N,) bool.

    Raises
    ------
    ValueError
        Bad points, k outside [3, N] (a `PointAtlasError`), or neighbour indices
        of the wrong shape or range.
    TypeError
        Non-integer k (bool and floats included) or neighbour indices.

    Notes
    -----
    Covariance of the k-neighbourhood about its mean (thesis 5.2, Eq. 5.4 with
    equal weights), normal = eigenvector of the smallest eigenvalue (Hoppe et al.
    1992). Degenerate neighbourhoods (decision, docs/decisions/normals.md): all points
    coincident -> normal (0, 0, 1); collinear -> a unit vector orthogonal to the
    line (the one orthogonal to the coordinate axis least aligned with it); both
    are flagged in ``is_degenerate``.

    Examples
    --------
    >>> import numpy as np
    >>> g = np.linspace(0, 1, 4)
    >>> pts = np.array([[x, y, 0.0] for x in g for y in g])
    >>> res = pca_normals(pts, 5)
    >>> np.abs(res.normals[:, 2]).min().round(6), res.n_degenerate
    (np.float64(1.0), 0)
    """
    pts = as_points(points)
    k = as_k(k, pts.shape[0], minimum=3)
    idx = _neighbor_indices(pts, k, neighbors)
    n = pts.shape[0]
    normals = np.empty((n, 3))
    eigenvalues = np.empty((n, 3))
    degenerate = np.empty(n, dtype=np.bool_)
    # the table read-only whether it came from query_knn or the caller: one signature
    pca_normals_kernel(
        pts, readonly_view(idx), k, NORMAL_DEGENERATE_RATIO, normals, eigenvalues, degenerate
    )
    return PCANormalsResult(normals=normals, eigenvalues=eigenvalues, is_degenerate=degenerate)


def estimate_normals(points, k: int = 20, *, neighbors=None, degenerate: str = "fallback"):
    """Unoriented PCA normals of a point set.

    Parameters
    ----------
    points : array_like of shape (N, 3)
        Coordinates (float64 after conversion, finite).
    k : int
        Neighbourhood size, the point itself included (3 <= k <= N; default 20).
    neighbors : ndarray of shape (N, m), int, or tuple, optional
        Precomputed neighbour indices with m >= k (the first k columns are used),
        or the tuple returned by `pointatlas.neighbors.query_knn`. Default: one
        call ``query_knn(points, k)``.
    degenerate : {"fallback", "nan"}
        What undefined normals (coincident or collinear neighbours) become:
        the documented fallback direction (default, always unit length) or NaN.
        `pca_normals` flags them either way.

    Returns
    -------
    normals : ndarray of shape (N, 3), float64
        Unit normals with arbitrary sign (orient them with `orient_normals`).

    Raises
    ------
    ValueError
        Bad points, k outside [3, N] (a `PointAtlasError`), bad neighbour
        indices, or unknown ``degenerate``.
    TypeError
        Non-integer k (bool and floats included) or neighbour indices.

    Notes
    -----
    See `pca_normals` (thesis 5.2; Hoppe et al. 1992). The eigenvector comes from
    a cyclic Jacobi eigen-solver per point in a parallel numba kernel, accurate
    also for nearly equal eigenvalues.

    Examples
    --------
    >>> import numpy as np
    >>> g = np.linspace(0, 1, 4)
    >>> pts = np.array([[x, 0.0, y] for x in g for y in g])
    >>> np.abs(estimate_normals(pts, 5)[:, 1]).round(6).tolist() == [1.0] * 16
    True
    """
    if degenerate not in ("fallback", "nan"):
        raise ValueError(f"degenerate must be 'fallback' or 'nan'; got {degenerate!r}")
    res = pca_normals(points, k, neighbors=neighbors)
    normals = np.array(res.normals)
    if degenerate == "nan":
        normals[res.is_degenerate] = np.nan
    return normals
