"""Normal voting tensor filtering [YRS+18] with adaptive k (thesis 5.4): the default
neighbourhoods and the filter steps. The point update that follows them is `_voting`."""

from __future__ import annotations

import numpy as np

from .._core import as_float, as_int, as_iterations, as_normals, as_points, readonly_view
from .._core.tolerances import (
    DENOISE_K_MAX,
    DENOISE_K_MIN,
    DENOISE_K_WIDTH,
    DENOISE_RADIUS_FACTOR,
)
from ..neighbors import mean_spacing, query_knn
from ..normals import estimate_normals, orient_normals
from ._kernels import adaptive_k_kernel, table_distances_kernel, voting_filter_kernel
from ._result import NormalFilterResult
from ._threads import threads_for

__all__ = ["THESIS_FILTER_PARAMETERS", "default_neighborhoods", "filter_normals"]

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


_STEP = "each filter step is a pass over every point"


def _check_common(points, normals, rho, tau, radius_factor, *, optional=False):
    pts = as_points(points, min_points=K_MIN + 1)
    nrm = None if optional and normals is None else as_normals(normals, pts.shape[0])
    rho = as_float(rho, "rho", lo=-1.0, hi=1.0, note="a cosine")
    tau = as_float(tau, "tau", lo=0.0, hi=1.0, lo_open=True)
    radius_factor = as_float(radius_factor, "radius_factor", lo=0.0, lo_open=True)
    return pts, nrm, rho, tau, radius_factor


def default_neighborhoods(
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
    >>> idx, k, ell = default_neighborhoods(plane_patch(20, 20).points)
    >>> int(k.min()) >= 7, idx.shape[1] == int(k.max())
    (True, True)
    """
    pts = as_points(points, min_points=K_MIN + 1)
    radius_factor = as_float(radius_factor, "radius_factor", lo=0.0, lo_open=True)
    extra = as_int(extra, "extra", lo=0)
    _, idx, k, ell = _neighbourhoods(pts, radius_factor, extra)
    return idx, k, ell


def _neighbourhoods(pts, radius_factor, extra, neighbors=None, spacing=None):
    """`default_neighborhoods` on validated input; returns (table, idx, k, l).

    ``table`` is the whole index table (queried: ``min(48 + extra, N)`` columns,
    so its first 20 columns can serve normal estimation; or ``neighbors``, a
    validated table of at least that many columns); ``idx`` its first
    max(k) + extra columns. The distances behind k and l are recomputed from the
    table (`table_distances_kernel`), so a tile with the same rows gets the same
    k; ``spacing`` given replaces l.
    """
    n = pts.shape[0]
    kcap = min(K_MAX, n)
    ncol = min(kcap + extra, n)
    table = query_knn(pts, ncol)[0] if neighbors is None else neighbors
    dist = np.empty((n, kcap))
    table_distances_kernel(readonly_view(pts), np.ascontiguousarray(table[:, :kcap]), dist)
    if spacing is not None:
        ell = spacing
    else:
        ell = float(np.mean(dist[:, 1:7])) if ncol > 6 else mean_spacing(pts, 6)
    inside = (dist <= radius_factor * ell).sum(axis=1)
    k = np.clip(inside, min(K_MIN, n), kcap).astype(np.int64)
    return table, np.ascontiguousarray(table[:, : min(int(k.max()) + extra, ncol)]), k, ell


def _estimated_normals(pts, table, k, like=None):
    """PCA normals (k-NN) from one table (queried here when ``table`` is too narrow).

    ``like`` None: oriented by `orient_normals` (MST, outward; its default 10-NN
    graph, all points when there are fewer). Otherwise each is signed like the row
    of ``like`` (later rounds).
    """
    need = min(max(k, 10), pts.shape[0])
    if table is None or table.shape[1] < need:
        table = query_knn(pts, need)[0]
    nrm = estimate_normals(pts, k, neighbors=table)
    if like is None:
        return orient_normals(pts, nrm, k=min(10, pts.shape[0]), neighbors=table)
    nrm[(nrm * like).sum(axis=1) < 0] *= -1.0
    return nrm


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
        ro_pts = readonly_view(pts)  # one kernel signature for API, CLI and tile inputs
    for _ in range(n_iter):
        if adaptive:
            adaptive_k_kernel(ro_pts, cur, idx, k_lo, k_hi, rho, best_k, best_e, masks)
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
        Default neighbourhood radius in units of l (`default_neighborhoods`).
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
    Reconstruction of [YRS+18] as thesis 5.4 uses it (docs/decisions/denoise.md): per point
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
    n_iter = as_iterations(n_iter, "n_iter", _STEP)
    with threads_for(pts.shape[0]):
        _, idx, k_def, _ = _neighbourhoods(pts, radius_factor, K_WIDTH if adaptive else 0)
        out, k_of, fallback = _filter_steps(
            pts,
            nrm,
            idx,
            k_def,
            rho=rho,
            tau=tau,
            n_iter=n_iter,
            adaptive=bool(adaptive),
            progress=progress,
        )
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
