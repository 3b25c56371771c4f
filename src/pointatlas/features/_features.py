"""Normal-weighted covariances and eigen-features (thesis 5.3, 6.1, 6.2)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field, fields

import numpy as np

from .._core import (
    PointAtlasError,
    as_int,
    as_k,
    as_points,
    check_neighbors,
    readonly,
    readonly_view,
)
from .._core._sort import morton_bits, morton_order
from ..neighbors import query_knn
from ._kernels import (
    N_FEATURES,
    N_OUT,
    OUT_EIGENVALUES,
    OUT_FEATURES,
    OUT_VECTOR_1,
    OUT_VECTOR_3,
    REASON_BAD_INDEX,
    REASON_FEW_DISTINCT,
    REASON_NONFINITE,
    REASON_OK,
    REASON_ZERO_EIGENSUM,
    REASON_ZERO_WEIGHTS,
    covariance_kernel,
    eigvals_batch_kernel,
    features_kernel,
    fused_kernel,
)
from ._weights import _check_ab, _unit_normals_or_nan, normal_angles

__all__ = [
    "FEATURE_NAMES",
    "REASON_CODES",
    "FeatureResult",
    "covariance_features",
    "eigen_features",
    "symmetric_eigenvalues",
    "weighted_covariances",
]

#: per-point features, in the order of the columns written by the kernel
FEATURE_NAMES = (
    "linearity",
    "planarity",
    "scattering",
    "e_dim",
    "omnivariance",
    "anisotropy",
    "change_of_curvature",
    "eigenentropy",
    "eigen_sum",
    "verticality",
    "flatness",
)

#: reason code -> meaning (uint8 per point; 0 = features defined)
REASON_CODES = {
    REASON_OK: "ok",
    REASON_NONFINITE: "non-finite coordinates or normals in the neighbourhood",
    REASON_ZERO_WEIGHTS: "all weights zero",
    REASON_FEW_DISTINCT: "fewer than 3 distinct points with positive weight",
    REASON_ZERO_EIGENSUM: "eigenvalue sum zero",
}


@dataclass(frozen=True, slots=True)
class FeatureResult:
    """Per-point eigen-features and the neighbourhood each point used.

    Attributes
    ----------
    eigenvalues : ndarray of shape (N, 3), float64
        lambda_1 >= lambda_2 >= lambda_3 >= 0 of the covariance (Eq. 5.4); NaN when
        degenerate.
    linearity, planarity, scattering : ndarray of shape (N,), float64
        Eq. 5.6.
    e_dim : ndarray of shape (N,), float64
        Eq. 5.7 (0 ln 0 = 0); +inf where an optimal search found no valid choice.
    omnivariance, anisotropy, change_of_curvature : ndarray of shape (N,), float64
        Eq. 6.2 on normalised eigenvalues (anisotropy reversed as in 6.2).
    eigenentropy, eigen_sum, verticality, flatness : ndarray of shape (N,), float64
        -sum e_i ln e_i; lambda_1 + lambda_2 + lambda_3; 1 - |v3_z|; Eq. 6.1.
    eigenvector_1, eigenvector_3 : ndarray of shape (N, 3), float64
        Unit eigenvectors of lambda_1 (main direction) and lambda_3 (PCA normal,
        sign arbitrary).
    k : ndarray of shape (N,), int64
        Neighbourhood size used (-1 where no choice was valid).
    a, b : ndarray of shape (N,), float64
        Sigmoid thresholds used (radians; pi, pi for equal weights; NaN if none).
    reason : ndarray of shape (N,), uint8
        0 where features are defined, else a code of `REASON_CODES`.
    flatness_exponents : tuple of int
        (m1, m2) of Eq. 6.1.
    """

    eigenvalues: np.ndarray
    linearity: np.ndarray
    planarity: np.ndarray
    scattering: np.ndarray
    e_dim: np.ndarray
    omnivariance: np.ndarray
    anisotropy: np.ndarray
    change_of_curvature: np.ndarray
    eigenentropy: np.ndarray
    eigen_sum: np.ndarray
    verticality: np.ndarray
    flatness: np.ndarray
    eigenvector_1: np.ndarray
    eigenvector_3: np.ndarray
    k: np.ndarray
    a: np.ndarray
    b: np.ndarray
    reason: np.ndarray
    flatness_exponents: tuple = field(default=(8, 8))

    def __post_init__(self):
        for f in fields(self):
            value = getattr(self, f.name)
            if isinstance(value, np.ndarray):
                object.__setattr__(self, f.name, readonly(value))

    @property
    def n_points(self) -> int:
        """Number of points."""
        return int(self.reason.shape[0])

    @property
    def is_valid(self) -> np.ndarray:
        """Boolean mask of points whose features are defined (reason == 0)."""
        return self.reason == REASON_OK

    def scalar_fields(self) -> dict[str, np.ndarray]:
        """All per-point scalars by name (for PLY scalar fields / CSV).

        Returns
        -------
        fields : dict of str to ndarray of shape (N,)
            ``eigenvalue_1..3``, every feature of `FEATURE_NAMES`, ``k``, ``a``,
            ``b`` (radians) and ``reason``.
        """
        out = {f"eigenvalue_{i + 1}": self.eigenvalues[:, i] for i in range(3)}
        for name in FEATURE_NAMES:
            out[name] = getattr(self, name)
        out["k"] = self.k
        out["a"] = self.a
        out["b"] = self.b
        out["reason"] = self.reason
        return out


def _check_flatness(flatness) -> tuple[int, int]:
    try:
        m1, m2 = flatness
    except (TypeError, ValueError):
        raise TypeError(f"flatness must be a pair of even integers; got {flatness!r}") from None
    m1 = as_int(m1, "flatness[0]", lo=0)
    m2 = as_int(m2, "flatness[1]", lo=0)
    if m1 % 2 or m2 % 2:
        raise PointAtlasError(
            f"flatness exponents m1, m2 must be even and >= 0 (Eq. 6.1); got {m1, m2}"
        )
    return m1, m2


def _neighbourhoods(
    points: np.ndarray, kmax: int, neighbors, *, check_range: bool = True
) -> np.ndarray:
    """(N, kmax) neighbour table, self first, sorted by distance.

    Computed with `query_knn` when ``neighbors`` is None (``points`` are finite,
    validated by the caller); otherwise the first ``kmax`` columns of the given
    table (index range checked here unless ``check_range`` is False:
    `_choice_features` checks it then).
    """
    if neighbors is not None:
        return check_neighbors(neighbors, points.shape[0], k=kmax, check_range=check_range)
    return query_knn(points, kmax)[0]


def _spatial_order(points: np.ndarray) -> np.ndarray:
    """Cache-friendly visiting order (about 16 points per grid cell, Morton order)."""
    return morton_order(points, morton_bits(points.shape[0]))


def packed_result(out, *, k, a, b, reason, flatness) -> FeatureResult:
    """The `FeatureResult` of a packed (N, `N_OUT`) kernel output; its arrays are
    views of the output's columns (one row per point in the kernels)."""
    feats = out[:, OUT_FEATURES:]
    return FeatureResult(
        eigenvalues=out[:, OUT_EIGENVALUES : OUT_EIGENVALUES + 3],
        eigenvector_1=out[:, OUT_VECTOR_1 : OUT_VECTOR_1 + 3],
        eigenvector_3=out[:, OUT_VECTOR_3 : OUT_VECTOR_3 + 3],
        k=k,
        a=a,
        b=b,
        reason=reason,
        flatness_exponents=flatness,
        **{name: feats[:, c] for c, name in enumerate(FEATURE_NAMES)},
    )


def _choice_features(points, idx, k_of, angles, a_of, b_of, flatness, order=None) -> FeatureResult:
    """Features at one (a, b, k) per point; ``k_of``, ``a_of``, ``b_of`` of length N or 1.

    ``order``: the visiting order when the caller has it (`_spatial_order`).
    """
    n = points.shape[0]
    out = np.empty((n, N_OUT))
    reason = np.empty(n, dtype=np.uint8)
    use_normals = angles is not None
    ang = angles if use_normals else np.empty((0, 0))
    m1, m2 = flatness
    if order is None:
        order = _spatial_order(points)
    # read-only points (as `as_points` gives them) also from tiles and tests: one signature
    pts = readonly_view(points)
    fused_kernel(pts, idx, order, k_of, ang, use_normals, a_of, b_of, m1, m2, out, reason)
    if (reason == REASON_BAD_INDEX).any():
        check_neighbors(idx, n)  # raises with the index range
    return packed_result(
        out,
        k=np.broadcast_to(np.asarray(k_of, dtype=np.int64), (n,)).copy(),
        a=np.broadcast_to(np.asarray(a_of, dtype=np.float64), (n,)).copy(),
        b=np.broadcast_to(np.asarray(b_of, dtype=np.float64), (n,)).copy(),
        reason=reason,
        flatness=(m1, m2),
    )


def weighted_covariances(points, neighbors, weights=None) -> tuple[np.ndarray, np.ndarray]:
    """Covariance matrices of Eq. 5.4 for every point's neighbourhood.

    Parameters
    ----------
    points : array_like of shape (N, 3)
        Coordinates, finite.
    neighbors : array_like of shape (N, k), int
        Neighbour indices of each point (the point itself included).
    weights : array_like of shape (N, k), optional
        Non-negative weights w_ij (e.g. `normal_weights`); all 1 when omitted.

    Returns
    -------
    covariances : ndarray of shape (N, 3, 3), float64
        C_i = sum_j w_ij (p_j - pbar_i)(p_j - pbar_i)^T with the *unweighted*
        barycentre pbar_i (Eq. 5.4 as printed).
    reason : ndarray of shape (N,), uint8
        Reason codes (`REASON_CODES`); the matrix is still returned for codes 2-3.

    Raises
    ------
    ValueError
        Bad shapes, negative weights or indices out of range; NaN or Inf in
        ``points`` (`NonFiniteError`).
    TypeError
        Non-integer ``neighbors``.

    Notes
    -----
    Computed relative to each point (a per-point origin) so large coordinate offsets
    do not cost precision.

    Examples
    --------
    >>> pts = [[0, 0, 0], [2, 0, 0], [0, 2, 0]]
    >>> cov, reason = weighted_covariances(pts, [[0, 1, 2]] * 3)
    >>> round(float(np.trace(cov[0])), 6), int(reason[0])
    (5.333333, 0)
    """
    pts = as_points(points)
    idx = check_neighbors(neighbors, pts.shape[0])
    if weights is None:
        w = np.empty((0, 0))
        use = False
    else:
        w = np.ascontiguousarray(np.asarray(weights, dtype=np.float64))
        if w.shape != idx.shape:
            raise ValueError(f"weights must have the shape of neighbors {idx.shape}; got {w.shape}")
        if (w < 0).any():
            raise ValueError("weights must be >= 0")
        use = True
    out = np.empty((pts.shape[0], 3, 3))
    reason = np.empty(pts.shape[0], dtype=np.uint8)
    covariance_kernel(pts, idx, w, use, out, reason)
    return out, reason


def symmetric_eigenvalues(matrices) -> np.ndarray:
    """Eigenvalues of a batch of symmetric 3x3 matrices, largest first.

    Parameters
    ----------
    matrices : array_like of shape (N, 3, 3)
        Symmetric matrices (the mean of a matrix and its transpose is used).

    Returns
    -------
    eigenvalues : ndarray of shape (N, 3), float64
        Descending; NaN rows for non-finite matrices.

    Raises
    ------
    ValueError
        Wrong shape.

    Notes
    -----
    Cyclic Jacobi rotations in a numba kernel with a relative stopping rule
    (small eigenvalues stay relatively accurate); agrees with
    `numpy.linalg.eigvalsh` to round-off.

    Examples
    --------
    >>> symmetric_eigenvalues([np.diag([1.0, 3.0, 2.0])]).tolist()
    [[3.0, 2.0, 1.0]]
    """
    m = np.asarray(matrices, dtype=np.float64)
    if m.ndim != 3 or m.shape[1:] != (3, 3):
        raise ValueError(f"matrices must have shape (N, 3, 3); got {m.shape}")
    out = np.empty((m.shape[0], 3))
    eigvals_batch_kernel(np.ascontiguousarray(m), out)
    return out


def eigen_features(eigenvalues, *, flatness=(8, 8)) -> dict[str, np.ndarray]:
    """Eigenvalue features (Eqs. 5.6, 5.7, 6.1, 6.2) from given eigenvalues.

    Parameters
    ----------
    eigenvalues : array_like of shape (N, 3)
        Eigenvalues in any order (sorted descending here; negatives from round-off
        clipped to 0).
    flatness : tuple of int
        Even exponents (m1, m2) of Eq. 6.1.

    Returns
    -------
    features : dict of str to ndarray of shape (N,)
        Every name of `FEATURE_NAMES` except ``verticality`` (which needs an
        eigenvector); NaN where lambda_1 <= 0 or the input is non-finite.

    Raises
    ------
    ValueError
        Wrong shape, odd or negative exponents.
    TypeError
        Non-integer exponents.

    Examples
    --------
    >>> f = eigen_features([[1.0, 1.0, 0.0]])
    >>> float(f["planarity"][0]), float(f["e_dim"][0]), float(f["flatness"][0])
    (1.0, 0.0, 0.0)
    """
    m1, m2 = _check_flatness(flatness)
    ev = np.asarray(eigenvalues, dtype=np.float64)
    if ev.ndim != 2 or ev.shape[1] != 3:
        raise ValueError(f"eigenvalues must have shape (N, 3); got {ev.shape}")
    ev = np.clip(-np.sort(-ev, axis=1), 0.0, None)
    reason = np.where(np.isfinite(ev).all(axis=1), REASON_OK, REASON_NONFINITE).astype(np.uint8)
    reason[(reason == REASON_OK) & ~(ev[:, 0] > 0)] = REASON_ZERO_EIGENSUM
    feats = np.empty((ev.shape[0], N_FEATURES))
    features_kernel(np.ascontiguousarray(ev), np.zeros((ev.shape[0], 3)), reason, m1, m2, feats)
    return {
        name: feats[:, c].copy() for c, name in enumerate(FEATURE_NAMES) if name != "verticality"
    }


def covariance_features(
    points,
    k: int = 14,
    *,
    normals=None,
    a: float = math.pi,
    b: float = math.pi,
    neighbors=None,
    flatness=(8, 8),
) -> FeatureResult:
    """Eigen-features of every point's k-neighbourhood (fixed-k mode).

    Parameters
    ----------
    points : array_like of shape (N, 3)
        Coordinates, finite.
    k : int
        Neighbourhood size, the point itself included (thesis 6.2 uses 14);
        1 <= k <= N.
    normals : array_like of shape (N, 3), optional
        Oriented normals; needed only for sigmoid weights (a < pi or b < pi).
    a : float
        Sigmoid start (radians in [0, pi], Def. 15); with ``b`` = pi, the
        default, weights are 1.
    b : float
        Sigmoid end (radians, [a, pi]).
    neighbors : array_like of shape (N, >= k), int, optional
        Precomputed neighbour table sorted by distance, the point itself first;
        computed with `pointatlas.neighbors.query_knn` when omitted.
    flatness : tuple of int
        Even exponents (m1, m2) of Eq. 6.1.

    Returns
    -------
    result : FeatureResult
        Features, eigenvalues, eigenvectors, the (a, b, k) used and reason codes.

    Raises
    ------
    ValueError
        Bad shapes/parameters (k outside [1, N], a or b outside their ranges or
        NaN, odd or negative flatness exponents); normals missing while a or
        b < pi.
    NonFiniteError
        NaN or Inf in ``points`` (a ``ValueError``; count and rows given).
    TypeError
        Non-integer k or flatness exponents, non-numeric a or b.

    Notes
    -----
    Covariance of Eq. 5.4 (weighted outer products about the unweighted
    barycentre), eigenvalues in closed form refined by deflation (accurate for
    double eigenvalues), features of Eqs. 5.6, 5.7, 6.1,
    6.2. Degenerate neighbourhoods (non-finite data, all weights zero, fewer than
    three distinct points with positive weight, eigenvalue sum zero) give NaN and a
    reason code (docs/decisions/features.md).

    Examples
    --------
    >>> import numpy as np
    >>> g = np.stack(np.meshgrid(np.arange(5.0), np.arange(5.0), [0.0]), -1).reshape(-1, 3)
    >>> r = covariance_features(g, k=9)
    >>> bool(np.nanmax(r.scattering) < 1e-12), int(r.reason.max())
    (True, 0)
    """
    pts = as_points(points)
    n = pts.shape[0]
    k = as_k(k, n)
    a, b = _check_ab(a, b)
    flat = _check_flatness(flatness)
    idx = _neighbourhoods(pts, k, neighbors, check_range=False)
    weighted = not (a == math.pi and b == math.pi)
    angles = None
    if weighted:
        if normals is None:
            raise ValueError("normals are required for sigmoid weights (a < pi or b < pi)")
        angles = normal_angles(_unit_normals_or_nan(normals, n), idx)
    k_of = np.array([k], dtype=np.int64)
    return _choice_features(pts, idx, k_of, angles, np.array([a]), np.array([b]), flat)
