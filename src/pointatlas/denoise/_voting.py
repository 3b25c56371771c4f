"""Normal voting tensor filtering [YRS+18] with adaptive k (thesis 5.4) and point update."""

from __future__ import annotations

import numpy as np

from .._core import PointAtlasError, as_float, as_int, as_normals, as_points
from .._core.tolerances import (
    DENOISE_K_MAX,
    DENOISE_K_MIN,
    DENOISE_K_WIDTH,
    DENOISE_RADIUS_FACTOR,
)
from ..neighbors import mean_spacing, query_knn
from ..normals import estimate_normals, orient_normals
from ._kernels import (
    adaptive_k_kernel,
    quadric_update_kernel,
    threads_for,
    voting_filter_kernel,
)
from ._result import DenoiseResult, NormalFilterResult

__all__ = [
    "THESIS_FILTER_PARAMETERS",
    "default_neighbourhoods",
    "filter_normals",
    "normal_voting_denoise",
]

#: (p, rho, tau) of thesis 5.4, taken from [YRS+18], by model
THESIS_FILTER_PARAMETERS = {
    "cube": (150, 0.95, 0.3),
    "fandisk": (150, 0.9, 0.3),
    "octahedron": (80, 0.9, 0.25),
    "rockerarm": (80, 0.9, 0.25),
    "bearing": (100, 0.9, 0.25),
    "sharp_sphere": (100, 0.9, 0.25),
    "fertility": (100, 0.9, 0.25),
}

#: default neighbourhood of [YRS+18] as reconstructed (docs/decisions/denoise.md):
#: the ball of radius RADIUS_FACTOR * l (l: mean 6-NN spacing), clamped to
#: [K_MIN, K_MAX] points; K_WIDTH: the thesis' range half-width, k in
#: [k_i - 10, k_i + 10]. The values and their reasons live in _core/tolerances.py.
RADIUS_FACTOR = DENOISE_RADIUS_FACTOR
K_MIN = DENOISE_K_MIN
K_MAX = DENOISE_K_MAX
K_WIDTH = DENOISE_K_WIDTH
#: columns added to the previous outer iteration's need when guessing the next
#: table's width (`_neighbourhoods` checks the guess and falls back to full width)
_WIDTH_MARGIN = 4


def _check_common(points, normals, rho, tau, radius_factor, *, optional=False):
    pts = as_points(points, min_points=K_MIN + 1)
    nrm = None if optional and normals is None else as_normals(normals, pts.shape[0])
    rho = as_float(rho, "rho", lo=-1.0, hi=1.0, note="a cosine")
    tau = as_float(tau, "tau", lo=0.0, hi=1.0, lo_open=True)
    radius_factor = as_float(radius_factor, "radius_factor", lo=0.0, lo_open=True)
    return pts, nrm, rho, tau, radius_factor


def default_neighbourhoods(
    points, *, radius_factor: float = RADIUS_FACTOR, extra: int = 0
) -> tuple[np.ndarray, np.ndarray, float]:
    """The default neighbourhoods of the normal voting filter ([YRS+18], reconstructed).

    Parameters
    ----------
    points : array_like of shape (N, 3), float64
        Coordinates, N > 7.
    radius_factor : float
        Ball radius in units of l, the mean 6-NN spacing (default 2).
    extra : int
        Extra columns of the table beyond the largest k (the adaptive range needs 10).

    Returns
    -------
    neighbors : ndarray of shape (N, K), int64
        Nearest neighbours sorted by distance, the point itself first;
        K = max(k) + extra (at most N).
    k : ndarray of shape (N,), int64
        k_i: the number of points within radius_factor * l of point i (itself
        included), clamped to [7, 48] and to N.
    spacing : float
        l.

    Raises
    ------
    ValueError
        Bad points, fewer than 8 points, radius_factor <= 0.

    Examples
    --------
    >>> from pointatlas.synth import plane_patch
    >>> idx, k, ell = default_neighbourhoods(plane_patch(20, 20).points)
    >>> int(k.min()) >= 7, idx.shape[1] == int(k.max())
    (True, True)
    """
    pts = as_points(points, min_points=K_MIN + 1)
    radius_factor = as_float(radius_factor, "radius_factor", lo=0.0, lo_open=True)
    extra = as_int(extra, "extra", lo=0)
    _, idx, k, ell = _neighbourhoods(pts, radius_factor, extra)
    return idx, k, ell


def _neighbourhoods(pts, radius_factor, extra, width=None):
    """`default_neighbourhoods` on validated input; returns (table, idx, k, l).

    ``table`` is the whole queried index table (at least ``min(48, N)`` columns
    when ``width`` is None, so its first 20 columns can serve normal estimation).
    ``width`` guesses the number of columns: a query of that many columns gives
    the same result when every row's last column lies outside the ball (then the
    ball's count is complete) and max(k) + extra fits; otherwise the full-width
    query runs. Rows of a narrower query are prefixes of the full one (ties by
    index), and l is the same mean (docs/decisions/denoise.md, "Speed").
    """
    n = pts.shape[0]
    kcap = min(K_MAX, n)
    ncol = min(kcap + extra, n)
    if width is not None and 6 < width < ncol:
        idx, dist = query_knn(pts, width)
        ell = float(np.mean(dist[:, 1:7]))
        r = radius_factor * ell
        if width >= kcap or bool((dist[:, width - 1] > r).all()):
            inside = (dist[:, : min(kcap, width)] <= r).sum(axis=1)
            k = np.clip(inside, min(K_MIN, n), kcap).astype(np.int64)
            if int(k.max()) + extra <= width:
                return idx, np.ascontiguousarray(idx[:, : int(k.max()) + extra]), k, ell
    idx, dist = query_knn(pts, ncol)
    ell = float(np.mean(dist[:, 1:7])) if ncol > 6 else mean_spacing(pts, 6)
    inside = (dist[:, :kcap] <= radius_factor * ell).sum(axis=1)
    k = np.clip(inside, min(K_MIN, n), kcap).astype(np.int64)
    return idx, np.ascontiguousarray(idx[:, : min(int(k.max()) + extra, ncol)]), k, ell


def _estimated_normals(pts, table, k):
    """PCA normals (k-NN) oriented by `orient_normals` (MST, outward; its default
    10-NN graph), from one table (queried here when ``table`` is too narrow)."""
    need = min(max(k, 10), pts.shape[0])
    if table is None or table.shape[1] < need:
        table = query_knn(pts, need)[0]
    return orient_normals(pts, estimate_normals(pts, k, neighbors=table), neighbors=table)


def _filter_steps(pts, nrm, idx, k_def, *, rho, tau, n_iter, adaptive, progress):
    """Run ``n_iter`` filter steps (Jacobi); returns (normals, k, fallback).

    Points stay fixed, so ``idx`` serves every step, and the adaptive k of a point
    is searched again only when its cut-off weights changed (`adaptive_k_kernel`).
    """
    n = pts.shape[0]
    ncol = idx.shape[1]
    cur = nrm.copy()
    nxt = np.empty_like(cur)
    k_of = k_def.copy()
    use_cut = np.ones(n, dtype=bool)
    fallback = np.zeros(n, dtype=bool)
    if adaptive:
        k_lo = np.maximum(k_def - K_WIDTH, 1).astype(np.int64)
        k_hi = np.minimum(k_def + K_WIDTH, ncol).astype(np.int64)
        best_k = np.empty(n, dtype=np.int64)
        best_e = np.empty(n)
        masks = np.full(n, -1, dtype=np.int64)
    for _ in range(n_iter):
        if adaptive:
            adaptive_k_kernel(pts, cur, idx, k_lo, k_hi, rho, best_k, best_e, masks)
            fallback = best_k < 0
            k_of = np.where(fallback, k_def, best_k)
            use_cut = ~fallback
        voting_filter_kernel(cur, idx, k_of, use_cut, rho, tau, nxt)
        cur, nxt = nxt, cur
        if progress is not None:
            progress(1)
    return cur, k_of, fallback


def filter_normals(
    points,
    normals,
    *,
    rho: float = 0.9,
    tau: float = 0.3,
    n_iter: int = 100,
    adaptive: bool = False,
    radius_factor: float = RADIUS_FACTOR,
    progress=None,
) -> NormalFilterResult:
    """Normal voting tensor filtering ([YRS+18] stage 1), optionally with adaptive k.

    Parameters
    ----------
    points : array_like of shape (N, 3), float64
        Coordinates (not moved), N > 7.
    normals : array_like of shape (N, 3), float64
        Oriented noisy normals (rescaled to unit length).
    rho : float
        Cut-off on n_i . n_j in [-1, 1]: only neighbours with n_i . n_j >= rho vote.
    tau : float
        Eigenvalue threshold in (0, 1].
    n_iter : int
        Iterations p (thesis 5.4: 80-150 by model, `THESIS_FILTER_PARAMETERS`).
    adaptive : bool
        The thesis' variant: before every iteration each point picks k in
        [k_i - 10, k_i + 10] (k_i its default size, values below 1 left out) with
        least E_dim (Eq. 5.7) under a = b = arccos(rho) cut-off weights.
    radius_factor : float
        Default neighbourhood radius in units of l (`default_neighbourhoods`).
    progress : callable, optional
        Called with 1 after every iteration.

    Returns
    -------
    result : NormalFilterResult
        Filtered normals and the neighbourhood sizes used.

    Raises
    ------
    ValueError
        Bad shapes, non-finite values, parameters out of range, fewer than 8 points.
    TypeError
        Non-integer n_iter.

    Notes
    -----
    Reconstruction of [YRS+18] (GUIDE C3; docs/decisions/denoise.md): per point
    T_i = sum_j w_ij n_j n_j^T, w_ij = [n_i . n_j >= rho]; eigenvalues scaled by the
    largest and set to 1 if >= tau else 0; n_i <- normalise(T~_i n_i). All points
    are updated together. In the adaptive variant, points where every k in the
    range degenerates (fewer than three weighted neighbours, zero eigenvalues) use
    the default k and equal weights (thesis 5.4).

    Examples
    --------
    >>> from pointatlas.synth import cube
    >>> m = cube(6)
    >>> r = filter_normals(m.points, m.normals, rho=0.95, tau=0.3, n_iter=5)
    >>> bool(np.allclose(r.normals, m.normals))
    True
    """
    pts, nrm, rho, tau, radius_factor = _check_common(points, normals, rho, tau, radius_factor)
    n_iter = as_int(n_iter, "n_iter", lo=0)
    with threads_for(pts.shape[0]):
        _, idx, k_def, _ = _neighbourhoods(pts, radius_factor, K_WIDTH if adaptive else 0)
        out, k_of, fallback = _filter_steps(
            pts, nrm, idx, k_def, rho=rho, tau=tau, n_iter=n_iter, adaptive=bool(adaptive),
            progress=progress,
        )  # fmt: skip
    return NormalFilterResult(
        normals=out,
        k=k_of,
        default_k=k_def,
        is_fallback=fallback,
        n_iter=n_iter,
        rho=rho,
        tau=tau,
        adaptive=bool(adaptive),
    )


def normal_voting_denoise(
    points,
    normals=None,
    *,
    rho: float = 0.9,
    tau: float = 0.3,
    n_iter: int = 2,
    n_filter_iter: int = 10,
    adaptive: bool = True,
    max_step: float = 0.5,
    sharpen: bool = False,
    radius_factor: float = RADIUS_FACTOR,
    normal_k: int = 20,
    progress=None,
) -> DenoiseResult:
    """Denoise points: normal voting filtering, feature classes and a restricted quadric update.

    Parameters
    ----------
    points : array_like of shape (N, 3), float64
        Noisy positions, N > 7.
    normals : array_like of shape (N, 3), float64, optional
        Oriented normals of the noisy points. None: PCA normals over ``normal_k``
        neighbours, oriented by `pointatlas.normals.orient_normals` (MST,
        outward; its default 10 neighbours), both from the first neighbour table
        (the same normals as `estimate_normals` and `orient_normals` on a fresh
        ``normal_k``-NN table, without the extra query).
    rho, tau : float
        Filter cut-off and eigenvalue threshold (`filter_normals`); tau also
        separates faces, edges and corners.
    n_iter : int
        Outer iterations: neighbourhoods, ``n_filter_iter`` filter steps, one point
        update (default 2).
    n_filter_iter : int
        Filter steps per outer iteration (default 10; 2 x 10 beat 4 x 20 in
        Chamfer and point-to-mesh on most benchmark inputs, docs/decisions/denoise.md).
    adaptive : bool
        Choose each point's k by least E_dim before every filter step (thesis 5.4);
        False gives the fixed default neighbourhoods of [YRS+18].
    max_step : float
        Bound on one point's move per iteration, in units of l (mean 6-NN spacing
        of the input).
    sharpen : bool
        Move edge and corner points within the span of the dominant normal
        directions onto the intersection of their neighbours' planes ([YRS+18]'s
        restricted update). Off by default: it also pulls face points within about
        one spacing of an edge onto the edge (tangential drift, measured in
        docs/decisions/denoise.md); off, every point moves along its own normal.
    radius_factor : float
        Default neighbourhood radius in units of l.
    normal_k : int
        Neighbours of the estimated normals (only when ``normals`` is None; 20).
    progress : callable, optional
        Called with 1 after every filter step.

    Returns
    -------
    result : DenoiseResult
        ``feature_class`` from the last update, ``normals`` the last filtered
        normals, ``energy`` NaN.

    Raises
    ------
    ValueError
        Bad shapes or values, fewer than 8 points.
    TypeError
        Non-integer counts.

    Notes
    -----
    Our reconstruction of [YRS+18]'s later stages (docs/decisions/denoise.md): a
    point is a face, edge or corner point by the number of eigenvalues >= tau
    (scaled by the largest) of the equal-weight voting tensor of its filtered
    neighbour normals; it moves within the span D of its own normal (face, and
    every point unless ``sharpen``) or of the tensor's dominant eigenvectors (edge:
    2, corner: 3) to minimise
    sum_j w_j (n_j . (x - p_j))^2 over its neighbours' filtered tangent planes
    (face points only use neighbours with n_i . n_j >= rho), the move clipped to
    max_step * l. All points move together; neighbourhoods are recomputed every
    outer iteration.

    Examples
    --------
    >>> from pointatlas.synth import plane_patch, add_normal_noise
    >>> m = plane_patch(16, 16)
    >>> noisy = add_normal_noise(m.points, m.normals, 0.3, rng=0)
    >>> r = normal_voting_denoise(noisy, m.normals, n_iter=2, n_filter_iter=5)
    >>> bool(abs(r.points[:, 2]).mean() < abs(noisy[:, 2]).mean())
    True
    """
    estimate = normals is None
    pts, nrm, rho, tau, radius_factor = _check_common(
        points, normals, rho, tau, radius_factor, optional=True
    )
    n_iter = as_int(n_iter, "n_iter", lo=0)
    n_filter_iter = as_int(n_filter_iter, "n_filter_iter", lo=0)
    max_step = as_float(max_step, "max_step", lo=0.0)
    normal_k = min(as_int(normal_k, "normal_k", lo=3), pts.shape[0])
    adaptive = bool(adaptive)
    extra = K_WIDTH if adaptive else 0
    n = pts.shape[0]
    ell = None
    cur = pts.copy()
    nxt = np.empty_like(cur)
    klass = np.ones(n, dtype=np.int64)
    k_of = np.zeros(n, dtype=np.int64)
    fallback = np.zeros(n, dtype=bool)
    width = None  # the first query is full width; with estimate=True it also serves
    table = None  # the normals (its first normal_k columns)
    with threads_for(n):
        for it in range(n_iter):
            table, idx, k_def, spacing = _neighbourhoods(cur, radius_factor, extra, width)
            if ell is None:  # l of the input, from the first table (no extra query)
                ell = spacing
            if it == 0 and estimate:
                nrm = _estimated_normals(cur, table, normal_k)
            # the next table is a few columns wider than this one's need (checked, exact)
            width = int(k_def.max()) + extra + _WIDTH_MARGIN
            nrm, k_of, fallback = _filter_steps(
                cur, nrm, idx, k_def, rho=rho, tau=tau, n_iter=n_filter_iter, adaptive=adaptive,
                progress=progress,
            )  # fmt: skip
            quadric_update_kernel(
                cur, nrm, idx, k_def, rho, tau, max_step * ell, bool(sharpen), nxt, klass
            )
            cur, nxt = nxt, cur
        if ell is None:
            ell = mean_spacing(pts, 6)
        if estimate and table is None:  # n_iter = 0: the normals are still wanted
            nrm = _estimated_normals(pts, None, normal_k)
    if not np.isfinite(cur).all():
        raise PointAtlasError("normal voting denoising produced non-finite points")
    return DenoiseResult(
        points=cur.copy(),
        normals=nrm,
        displacement=np.sqrt(((cur - pts) ** 2).sum(axis=1)),
        feature_class=klass.astype(np.int8) if n_iter else np.zeros(n, dtype=np.int8),
        energy=np.full(n, np.nan),
        k=k_of,
        method="normal-voting-adaptive" if adaptive else "normal-voting",
        n_iter=n_iter,
        n_fallback=int(fallback.sum()),
        spacing=ell,
    )
