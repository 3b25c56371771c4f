"""Optimal neighbourhoods: the (a, b, k) search of Eq. 5.9 and Weinmann's optimal k."""

from __future__ import annotations

import functools
import math

import numpy as np

from .._core import PointAtlasError, as_float_array, as_k, as_points
from ._features import (
    FeatureResult,
    _check_flatness,
    _choice_features,
    _neighbourhoods,
    _spatial_order,
    _unit_normals_or_nan,
    packed_result,
)
from ._kernels import N_OUT, REASON_OK, edim_table, optimal_kernel
from ._weights import normal_angles

__all__ = [
    "THESIS_ANGLE_GRID",
    "THESIS_K_RANGE",
    "angle_pairs",
    "decrease_cases",
    "optimal_k_features",
    "optimal_neighborhood",
]

#: A = B = {0, pi/6, ..., pi} of thesis 5.4 (7 values, 28 pairs a <= b)
THESIS_ANGLE_GRID = tuple(i * math.pi / 6 for i in range(7))
#: K = {6, ..., 20} of thesis 5.4, as an inclusive (min, max) range
THESIS_K_RANGE = (6, 20)

_CRITERIA = {"e_dim": 0, "eigenentropy": 1}


@functools.cache
def _edim_bounds() -> np.ndarray:
    """The search's table of certified E_dim lower bounds (`edim_table`), built once."""
    table = edim_table()
    table.flags.writeable = False
    return table


def _no_table() -> np.ndarray:
    """An empty table (no pruning), read-only like `_edim_bounds` so that numba
    compiles `optimal_kernel` once for both criteria, not once per array type."""
    table = np.empty((0, 0))
    table.flags.writeable = False
    return table


def _check_grid(grid, name: str) -> np.ndarray:
    """A non-empty grid of finite angles in [0, pi] radians, sorted and de-duplicated.

    Values at most 1e-12 above pi (round-off of a degree conversion) count as pi.
    """
    arr = np.asarray(grid) if grid is not None else grid
    if arr is not None and arr.dtype.kind == "f":
        arr = np.where((arr > math.pi) & (arr <= math.pi + 1e-12), math.pi, arr)
    g = as_float_array(arr, name, lo=0.0, hi=math.pi, what="angles", unit="radians")
    return np.unique(g)


def _check_k_range(k_range, n_points: int) -> tuple[int, int]:
    """An inclusive (k_min, k_max) with 1 <= k_min <= k_max <= N (k counts the point)."""
    try:
        kmin, kmax = k_range
    except (TypeError, ValueError):
        raise TypeError(f"k_range must be a pair (k_min, k_max); got {k_range!r}") from None
    kmin = as_k(kmin, n_points, name="k_range[0]")
    kmax = as_k(kmax, n_points, name="k_range[1]")
    if kmin > kmax:
        raise PointAtlasError(f"k_range must have k_min <= k_max; got {k_range!r}")
    return kmin, kmax


def angle_pairs(a_grid=THESIS_ANGLE_GRID, b_grid=THESIS_ANGLE_GRID) -> np.ndarray:
    """All (a, b) with a in ``a_grid``, b in ``b_grid`` and a <= b, in lexicographic order.

    Parameters
    ----------
    a_grid, b_grid : sequence of float
        Thresholds in radians within [0, pi].

    Returns
    -------
    pairs : ndarray of shape (M, 2), float64
        Sorted by a, then b (the tie order of the search).

    Raises
    ------
    ValueError
        Empty grids, values that are NaN, infinite or outside [0, pi], grids of
        more than one dimension, or no pair with a <= b.
    TypeError
        Non-numeric or boolean grid values.

    Examples
    --------
    >>> angle_pairs().shape
    (28, 2)
    """
    ag = _check_grid(a_grid, "a_grid")
    bg = _check_grid(b_grid, "b_grid")
    pairs = np.array([(a, b) for a in ag for b in bg if a <= b], dtype=np.float64)
    if pairs.size == 0:
        raise PointAtlasError("no (a, b) pair with a <= b in the given grids")
    return pairs.reshape(-1, 2)


def optimal_neighborhood(
    points,
    normals,
    *,
    a_grid=THESIS_ANGLE_GRID,
    b_grid=THESIS_ANGLE_GRID,
    k_range=THESIS_K_RANGE,
    neighbors=None,
    flatness=(8, 8),
) -> FeatureResult:
    """Per point the (a, b, k) minimising E_dim (thesis Eq. 5.9) and its features.

    Parameters
    ----------
    points : array_like of shape (N, 3)
        Coordinates, finite.
    normals : array_like of shape (N, 3)
        Oriented normals (the weights of Eq. 5.2 use their angles).
    a_grid, b_grid : sequence of float
        Sigmoid thresholds in radians, finite, in [0, pi], not empty (default:
        {0, pi/6, ..., pi}; 28 pairs a <= b).
    k_range : tuple of int
        Inclusive neighbourhood sizes (default 6..20; the point itself counts),
        1 <= k_min <= k_max <= N.
    neighbors : array_like of shape (N, >= k_max), int, optional
        Precomputed neighbour table sorted by distance, itself first.
    flatness : tuple of int
        Even exponents of Eq. 6.1 for the reported flatness.

    Returns
    -------
    result : FeatureResult
        Features at each point's optimal triple; ``a``, ``b``, ``k`` hold the
        triple. Where every choice degenerates, ``e_dim`` is +inf, ``k`` is -1,
        ``a``/``b`` and the other features NaN, and ``reason`` says why.

    Raises
    ------
    ValueError
        Bad shapes, grids (empty, NaN, outside [0, pi]) or range (k outside
        [1, N], k_min > k_max).
    NonFiniteError
        NaN or Inf in ``points`` (a ``ValueError``; count and rows given).
    TypeError
        Non-integer k, non-numeric grid values.

    Notes
    -----
    Each point's neighbours are sorted once; for every (a, b) the weighted moments
    (sum w, sum w y, sum w y y^T about the point) and the unweighted sum grow by one
    neighbour per k, so the 420 choices cost one covariance each in O(1) plus a
    closed-form eigenvalue solve; pairs selecting the same neighbours with 0/1
    weights are evaluated once. Ties: smallest k, then a, then b. A
    choice is degenerate when fewer than three distinct points carry positive
    weight or the eigenvalue sum is 0 (5.3.2). The reported features are then
    recomputed at the chosen triple with the accurate (deflated) solver.

    Examples
    --------
    >>> import numpy as np
    >>> rng = np.random.default_rng(0)
    >>> pts = rng.random((60, 3))
    >>> r = optimal_neighborhood(pts, np.tile([0.0, 0.0, 1.0], (60, 1)))
    >>> bool(((r.k >= 6) & (r.k <= 20)).all())
    True
    """
    pts = as_points(points)
    n = pts.shape[0]
    pairs = angle_pairs(a_grid, b_grid)
    kmin, kmax = _check_k_range(k_range, n)
    flat = _check_flatness(flatness)
    nrm = _unit_normals_or_nan(normals, n)
    idx = _neighbourhoods(pts, kmax, neighbors)
    return _run_optimal(pts, nrm, idx, kmin, kmax, pairs, criterion=0, flatness=flat)


def optimal_k_features(
    points,
    *,
    k_range=(10, 50),
    criterion: str = "eigenentropy",
    neighbors=None,
    flatness=(8, 8),
) -> FeatureResult:
    """Weinmann et al.'s optimal neighbourhood size with equal weights, and its features.

    Parameters
    ----------
    points : array_like of shape (N, 3)
        Coordinates, finite.
    k_range : tuple of int
        Inclusive range of k (the point itself counts), 1 <= k_min <= k_max <= N;
        default 10..50 as pgeof.
    criterion : {"eigenentropy", "e_dim"}
        Minimised quantity: eigenentropy of the normalised eigenvalues ([WJM14]) or
        the dimensionality entropy E_dim of Eq. 5.7 (the thesis' equal-weight
        baseline of Table 5.1 uses "e_dim" with k in 6..20).
    neighbors : array_like of shape (N, >= k_max), int, optional
        Precomputed neighbour table sorted by distance, itself first.
    flatness : tuple of int
        Even exponents of Eq. 6.1.

    Returns
    -------
    result : FeatureResult
        Features at each point's optimal k (``a`` = ``b`` = pi); e_dim +inf and
        k = -1 where no k is valid.

    Raises
    ------
    ValueError
        Unknown criterion, bad range (k outside [1, N], k_min > k_max).
    NonFiniteError
        NaN or Inf in ``points`` (a ``ValueError``; count and rows given).
    TypeError
        Non-integer k.

    Notes
    -----
    Same running-sum kernel as `optimal_neighborhood` with one all-ones weight
    vector. Ties: smallest k.

    Examples
    --------
    >>> import numpy as np
    >>> r = optimal_k_features(np.random.default_rng(1).random((80, 3)), k_range=(6, 12))
    >>> int(r.k.min()) >= 6 and int(r.k.max()) <= 12
    True
    """
    if criterion not in _CRITERIA:
        raise ValueError(f"criterion must be one of {sorted(_CRITERIA)}; got {criterion!r}")
    pts = as_points(points)
    kmin, kmax = _check_k_range(k_range, pts.shape[0])
    flat = _check_flatness(flatness)
    idx = _neighbourhoods(pts, kmax, neighbors)
    pairs = np.array([[math.pi, math.pi]])
    return _run_optimal(
        pts, None, idx, kmin, kmax, pairs, criterion=_CRITERIA[criterion], flatness=flat
    )


def _run_optimal(pts, nrm, idx, kmin, kmax, pairs, *, criterion, flatness) -> FeatureResult:
    """One `optimal_kernel` pass: the argmin per point and the features there."""
    n = pts.shape[0]
    out = np.empty((n, N_OUT))
    reason = np.empty(n, dtype=np.uint8)
    best_k = np.empty(n, dtype=np.int64)
    best_pair = np.empty(n, dtype=np.int64)
    use_normals = nrm is not None
    m1, m2 = flatness
    optimal_kernel(
        pts,
        nrm if use_normals else np.empty((0, 3)),
        idx,
        _spatial_order(pts),
        kmin,
        kmax,
        use_normals,
        np.ascontiguousarray(pairs[:, 0]),
        np.ascontiguousarray(pairs[:, 1]),
        criterion,
        m1,
        m2,
        out,
        reason,
        best_k,
        best_pair,
        _edim_bounds() if criterion == 0 else _no_table(),
    )
    ok = reason == REASON_OK
    pair = np.where(ok, best_pair, 0)
    return packed_result(
        out,
        k=best_k,
        a=np.where(ok, pairs[pair, 0], np.nan),
        b=np.where(ok, pairs[pair, 1], np.nan),
        reason=reason,
        flatness=(m1, m2),
    )


def decrease_cases(
    points,
    normals,
    result: FeatureResult,
    *,
    a_grid=THESIS_ANGLE_GRID,
    b_grid=THESIS_ANGLE_GRID,
    neighbors=None,
) -> tuple[np.ndarray, np.ndarray]:
    """Table 5.2's cases: could the chosen a or b go one grid step lower?

    Parameters
    ----------
    points : array_like of shape (N, 3)
        The coordinates the search ran on.
    normals : array_like of shape (N, 3)
        The normals the search ran on.
    result : FeatureResult
        Output of `optimal_neighborhood` on these points and grids.
    a_grid, b_grid : sequence of float
        The grids of the search (radians).
    neighbors : array_like of shape (N, >= k_max), int, optional
        The neighbour table of the search.

    Returns
    -------
    a_case : ndarray of shape (N,), int8
        0: a* is the smallest grid value ("a = 0"); 1: a one step lower (same b*, k*)
        gives a non-degenerate covariance ("a-"); 2: it degenerates ("not a-");
        -1: no valid triple.
    b_case : ndarray of shape (N,), int8
        0: b* = a* or no grid value in [a*, b*) ("b = a"); 1: b one step lower is
        non-degenerate ("b-"); 2: it degenerates ("not b-"); -1: no valid triple.

    Raises
    ------
    ValueError
        Shapes that do not match ``result``; bad grids (as `angle_pairs`).

    Examples
    --------
    >>> import numpy as np
    >>> pts = np.random.default_rng(0).random((40, 3))
    >>> nrm = np.tile([0.0, 0.0, 1.0], (40, 1))
    >>> r = optimal_neighborhood(pts, nrm)
    >>> a_case, b_case = decrease_cases(pts, nrm, r)
    >>> sorted(set(a_case.tolist()))
    [0]
    """
    pts = as_points(points)
    n = pts.shape[0]
    if result.n_points != n:
        raise ValueError(f"result has {result.n_points} points; points has {n}")
    ag = _check_grid(a_grid, "a_grid")
    bg = _check_grid(b_grid, "b_grid")
    ok = result.reason == REASON_OK
    kmax = int(result.k[ok].max()) if ok.any() else 1
    idx = _neighbourhoods(pts, kmax, neighbors)
    angles = normal_angles(_unit_normals_or_nan(normals, n), idx)
    a_star = np.where(ok, result.a, ag[0])
    b_star = np.where(ok, result.b, bg[-1])
    k_of = np.where(ok, result.k, kmax).astype(np.int64)

    ia = np.searchsorted(ag, a_star - 1e-12)
    a_min = ia == 0
    a_low = ag[np.maximum(ia - 1, 0)]
    ra = _choice_features(pts, idx, k_of, angles, a_low, b_star, (2, 2)).reason
    a_case = np.where(a_min, 0, np.where(ra == REASON_OK, 1, 2)).astype(np.int8)

    ib = np.searchsorted(bg, b_star - 1e-12)
    b_low = bg[np.maximum(ib - 1, 0)]
    b_min = (ib == 0) | (b_low < a_star - 1e-12) | (np.abs(b_star - a_star) <= 1e-12)
    rb = _choice_features(pts, idx, k_of, angles, a_star, np.maximum(b_low, a_star), (2, 2)).reason
    b_case = np.where(b_min, 0, np.where(rb == REASON_OK, 1, 2)).astype(np.int8)
    a_case[~ok] = -1
    b_case[~ok] = -1
    return a_case, b_case
