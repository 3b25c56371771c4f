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
from ._kernels import (
    adaptive_k_kernel,
    quadric_update_kernel,
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


def _check_common(points, normals, rho, tau, radius_factor):
    pts = as_points(points, min_points=K_MIN + 1)
    nrm = as_normals(normals, pts.shape[0])
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
    n = pts.shape[0]
    kcap = min(K_MAX, n)
    ncol = min(kcap + extra, n)
    idx, dist = query_knn(pts, ncol)
    ell = float(np.mean(dist[:, 1:7])) if ncol > 6 else mean_spacing(pts, 6)
    inside = (dist[:, :kcap] <= radius_factor * ell).sum(axis=1)
    k = np.clip(inside, min(K_MIN, n), kcap).astype(np.int64)
    return np.ascontiguousarray(idx[:, : min(int(k.max()) + extra, ncol)]), k, ell


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
    idx, k_def, _ = default_neighbourhoods(
        pts, radius_factor=radius_factor, extra=K_WIDTH if adaptive else 0
    )
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
    normals,
    *,
    rho: float = 0.9,
    tau: float = 0.3,
    n_iter: int = 2,
    n_filter_iter: int = 10,
    adaptive: bool = True,
    max_step: float = 0.5,
    sharpen: bool = False,
    radius_factor: float = RADIUS_FACTOR,
    progress=None,
) -> DenoiseResult:
    """Denoise points: normal voting filtering, feature classes and a restricted quadric update.

    Parameters
    ----------
    points : array_like of shape (N, 3), float64
        Noisy positions, N > 7.
    normals : array_like of shape (N, 3), float64
        Oriented normals of the noisy points (e.g. estimated and oriented).
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
    pts, nrm, rho, tau, radius_factor = _check_common(points, normals, rho, tau, radius_factor)
    n_iter = as_int(n_iter, "n_iter", lo=0)
    n_filter_iter = as_int(n_filter_iter, "n_filter_iter", lo=0)
    max_step = as_float(max_step, "max_step", lo=0.0)
    adaptive = bool(adaptive)
    n = pts.shape[0]
    ell = None
    cur = pts.copy()
    nxt = np.empty_like(cur)
    klass = np.ones(n, dtype=np.int64)
    k_of = np.zeros(n, dtype=np.int64)
    fallback = np.zeros(n, dtype=bool)
    for _ in range(n_iter):
        idx, k_def, spacing = default_neighbourhoods(
            cur, radius_factor=radius_factor, extra=K_WIDTH if adaptive else 0
        )
        if ell is None:  # l of the input, from the first table (no extra query)
            ell = spacing
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
