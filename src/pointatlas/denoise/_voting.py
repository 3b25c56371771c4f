"""Normal voting tensor filtering [YRS+18] with adaptive k (thesis 5.4) and point update."""

from __future__ import annotations

import numpy as np

from .._core import (
    PointAtlasError,
    as_float,
    as_int,
    as_iterations,
    as_normals,
    as_points,
    readonly_view,
)
from .._core.tolerances import (
    DENOISE_K_MAX,
    DENOISE_K_MIN,
    DENOISE_K_WIDTH,
    DENOISE_RADIUS_FACTOR,
)
from ..neighbors import mean_spacing, query_knn
from ..normals import estimate_normals, orient_normals
from ._defaults import (
    LONELY_PASSES,
    LONELY_PLANES,
    LONELY_SIGMA,
    MAX_ROUNDS,
    MAX_UPDATES,
    POLISH_K,
    POLISH_LAMBDA,
    POLISH_MOVE,
    POLISH_NORMAL_K,
    default_filter_iter,
)
from ._kernels import (
    adaptive_k_kernel,
    face_normals_kernel,
    feature_class_kernel,
    lonely_normals_kernel,
    plane_lists_kernel,
    plane_update_kernel,
    polish_kernel,
    table_distances_kernel,
    voting_filter_kernel,
)
from ._result import DenoiseResult, NormalFilterResult
from ._sharpen import quadric_update_kernel
from ._tables import check_table
from ._threads import threads_for

__all__ = [
    "THESIS_FILTER_PARAMETERS",
    "default_neighborhoods",
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
#: point update (docs/decisions/denoise.md, "Point update"): Gaussian weight scale
#: of the neighbours' planes, in l, in the first round and in later rounds
UPDATE_SIGMA = 1.0
UPDATE_SIGMA_LATER = 1.5
#: ``n_update=None``: updates until one moves the points by an RMS below
#: UPDATE_STOP l, at most MAX_UPDATES per round
UPDATE_STOP = 0.05
#: ``n_iter=None``: another round (normals re-estimated from the moved points,
#: filtered, updates) while the last round moved the points by an RMS above
#: ROUND_MOVE l (high noise), at most MAX_ROUNDS rounds
ROUND_MOVE = 0.4
#: `normal_voting_denoise`'s filter ball (docs/decisions/denoise.md, "Filter steps per
#: round and ball"): POINT_RADIUS_FACTOR l (clamped to [7, 48] points); its filter steps
#: per round are `default_filter_iter`. `filter_normals` keeps the thesis' 2 l ball.
POINT_RADIUS_FACTOR = 3.5
#: PCA neighbours of the normals of later rounds (at least; the moved points are
#: smoother, a wider fit helps curved parts; docs/decisions/denoise.md)
LATER_NORMAL_K = 30
#: the update's plane normal (2 - beta) n_i + beta n_j in later rounds (1 in the
#: first: the symmetric form; docs/decisions/denoise.md, "Later rounds' planes")
PLANE_BETA_LATER = 0.75


_STEP = "each filter step is a pass over every point"
_ROUND = "each round is a pass over every point"


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


def _updates(
    cur, nrm, idx, k_def, lists, counts, *, rho, tau, step, sigma, beta, stop, n_update, sharpen
):
    """Point updates of one round with fixed normals and neighbours (Jacobi).

    ``lists``/``counts``: the planes of each point (`plane_lists_kernel` on ``nrm``);
    ``beta`` the plane normal's share of the neighbour's normal (`plane_update_kernel`).
    ``n_update`` None: until one update moves the points by an RMS below
    ``stop``, at most MAX_UPDATES (``step``, ``sigma`` and ``stop`` in the
    input's units). Returns the new positions.
    """
    n = cur.shape[0]
    nxt = np.empty_like(cur)
    klass = np.empty(n, dtype=np.int64)
    moved2 = np.empty(n)
    inv_sigma2 = 1.0 / (sigma * sigma) if sigma > 0.0 else 0.0
    for _ in range(MAX_UPDATES if n_update is None else n_update):
        if sharpen:
            quadric_update_kernel(cur, nrm, idx, k_def, rho, tau, step, True, nxt, klass)
            moved2 = ((nxt - cur) ** 2).sum(axis=1)
        else:
            plane_update_kernel(cur, nrm, lists, counts, step, inv_sigma2, beta, nxt, moved2)
        moved = float(np.sqrt(moved2.mean()))
        cur, nxt = nxt, cur
        if n_update is None and moved < stop:
            break
    return cur


def _planes(cur, nrm, idx, k_def, lists, counts, rho, ell):
    """The planes of a round: ``lists``/``counts`` (`plane_lists_kernel`) after
    LONELY_PASSES passes of `lonely_normals_kernel` (points with fewer than
    LONELY_PLANES planes take their neighbours' normals, Gaussian weights of
    LONELY_SIGMA l); returns the normals the planes were built from."""
    plane_lists_kernel(nrm, idx, k_def, rho, lists, counts)
    inv_sigma2 = 1.0 / (LONELY_SIGMA * ell) ** 2
    for _ in range(LONELY_PASSES):
        fixed = np.empty_like(nrm)
        lonely_normals_kernel(cur, nrm, idx, k_def, counts, rho, LONELY_PLANES, inv_sigma2, fixed)
        nrm = fixed
        plane_lists_kernel(nrm, idx, k_def, rho, lists, counts)
    return nrm


def _polish(cur, table):
    """One projected Laplacian step of moved points over the input's ``table``
    (`polish_kernel`, POLISH_LAMBDA, POLISH_K, POLISH_NORMAL_K; docs/decisions/denoise.md,
    "Polish")."""
    out = np.empty_like(cur)
    k_normal = min(POLISH_NORMAL_K, table.shape[1])
    polish_kernel(cur, table, k_normal, min(POLISH_K, k_normal), POLISH_LAMBDA, out)
    return out


def _rounds(
    pts,
    nrm,
    table,
    idx,
    k_def,
    ell,
    *,
    rounds,
    auto,
    rho,
    tau,
    n_filter_iter,
    n_update,
    adaptive,
    max_step,
    sharpen,
    normal_k,
    refit,
    progress,
):
    """The rounds of `normal_voting_denoise`, then the returned normals and classes.

    The returned normals: ``n_filter_iter`` more filter steps on the final
    positions, or with ``refit`` (estimated normals) the last round's normals
    refitted to the points of each point's face (`face_normals_kernel`).

    Returns (points, normals, k, is_fallback, feature_class, rounds run).
    """
    n = pts.shape[0]
    cur = pts
    k_of = np.zeros(n, dtype=np.int64)
    fallback = np.zeros(n, dtype=bool)
    klass = np.zeros(n, dtype=np.int64)
    ran = 0
    later_k = max(normal_k, min(LATER_NORMAL_K, n))
    lists = np.empty_like(idx)
    counts = np.empty(n, dtype=np.int64)
    for ran in range(1, rounds + 1):
        if ran > 1:  # PCA normals of the moved points, signed like the last ones
            nrm = _estimated_normals(cur, table, later_k, like=nrm)
        nrm, k_of, fallback = _filter_steps(
            cur,
            nrm,
            idx,
            k_def,
            rho=rho,
            tau=tau,
            n_iter=n_filter_iter,
            adaptive=adaptive,
            progress=progress,
        )
        nrm = _planes(readonly_view(cur), nrm, idx, k_def, lists, counts, rho, ell)  # 1 kernel type
        sigma = (UPDATE_SIGMA if ran == 1 else UPDATE_SIGMA_LATER) * ell
        start = cur
        cur = _updates(
            cur.copy(),
            nrm,
            idx,
            k_def,
            lists,
            counts,
            rho=rho,
            tau=tau,
            step=max_step * ell,
            sigma=sigma,
            beta=1.0 if ran == 1 else PLANE_BETA_LATER,
            stop=UPDATE_STOP * ell,
            n_update=n_update,
            sharpen=sharpen,
        )
        moved = float(np.sqrt(((cur - start) ** 2).sum(axis=1).mean()))
        if auto and moved <= ROUND_MOVE * ell:
            break
    if auto and ran > 1 and not sharpen and moved > POLISH_MOVE * ell:
        cur = _polish(cur, table)  # about 1 l of noise left after the rounds
    if ran and not refit:  # the returned normals: n_filter_iter more steps (sharper edges)
        nrm, k_of, fallback = _filter_steps(
            cur,
            nrm,
            idx,
            k_def,
            rho=rho,
            tau=tau,
            n_iter=n_filter_iter,
            adaptive=adaptive,
            progress=progress,
        )
    if ran:
        feature_class_kernel(nrm, idx, k_def, tau, klass)
    if ran and refit:  # estimated normals: each point's plane fitted to its face's points
        face = np.empty_like(nrm)
        face_normals_kernel(cur, nrm, lists, counts, face)  # the last round's planes
        nrm = face
    return cur, nrm, k_of, fallback, klass, ran


def normal_voting_denoise(
    points,
    normals=None,
    *,
    rho: float = 0.9,
    tau: float = 0.3,
    n_iter: int | None = None,
    n_filter_iter: int | None = None,
    n_update: int | None = None,
    adaptive: bool = True,
    max_step: float = 0.5,
    sharpen: bool = False,
    radius_factor: float = POINT_RADIUS_FACTOR,
    normal_k: int = 20,
    neighbors=None,
    spacing: float | None = None,
    refit_normals: bool | None = None,
    progress=None,
) -> DenoiseResult:
    """Denoise points: normal voting filtering, then point updates onto the filtered planes.

    Parameters
    ----------
    points : array_like of shape (N, 3), float64
        Noisy positions, N > 7.
    normals : array_like of shape (N, 3), float64, optional
        Oriented normals of the noisy points. None: PCA normals over ``normal_k``
        neighbours, oriented by `pointatlas.normals.orient_normals` (MST,
        outward; its default 10 neighbours), both from the neighbour table.
    rho, tau : float
        Filter cut-off and eigenvalue threshold (`filter_normals`); rho also
        picks the planes of the update, tau separates faces, edges and corners.
    n_iter : int, optional
        Rounds. None (default): until one moves the points by an RMS of at most
        0.4 l (``ROUND_MOVE``), at most 4; a polish step when a later one moved
        them by more than 0.28 l (``POLISH_MOVE``; docs/decisions/denoise.md).
    n_filter_iter : int, optional
        Filter steps per round (and of unrefitted returned normals); None:
        `default_filter_iter` (1 when the returned normals are refitted, else 5).
    n_update : int, optional
        Point updates per round. None (default): until one moves the points by
        an RMS below 0.05 l (``UPDATE_STOP``), at most 12.
    adaptive : bool
        Choose each point's k by least E_dim before every filter step (thesis 5.4);
        False gives the fixed default neighbourhoods of [YRS+18].
    max_step : float
        Bound on one point's move per update, in units of l.
    sharpen : bool
        Use [YRS+18]'s restricted quadric update instead (off by default: it also
        pulls face points near an edge onto it, docs/decisions/denoise.md).
    radius_factor : float
        Neighbourhood radius in l (default 3.5; [7, 48] points, `default_neighborhoods`).
    normal_k : int
        Neighbours of the PCA normals of the input when ``normals`` is None
        (default 20); rounds after the first fit max(normal_k, 30) moved points.
    neighbors : array_like of shape (N, K), int, optional
        The input's k-NN table (point itself first, then by distance and index,
        as `pointatlas.neighbors.query_knn` gives it), K >= min(48, N) (+10 with
        ``adaptive``); None: queried here.
    spacing : float, optional
        l, the unit of the radius, the step bound and the stops; None: the mean
        6-NN spacing of the input. Tiles pass the untiled run's l
        (``DenoiseResult.spacing``; with fixed counts: the untiled result, `denoise_halo`).
    refit_normals : bool, optional
        Return each point's normal refitted to the points of its face (the
        neighbours within the cut-off rho) instead of ``n_filter_iter`` more
        filter steps; None: when the normals are estimated (PCA normals blend
        across edges; docs/decisions/denoise.md).
    progress : callable, optional
        Called with 1 after every filter step.

    Returns
    -------
    result : DenoiseResult
        ``normals`` the returned normals, ``feature_class`` from the last
        round's, ``n_iter`` the rounds run, ``energy`` NaN, ``spacing`` l.

    Raises
    ------
    ValueError
        Bad shapes or values, fewer than 8 points, a bad ``neighbors`` table.
    TypeError
        Non-integer counts.

    Notes
    -----
    docs/decisions/denoise.md: one neighbour table of the input serves every round.
    A round filters the normals, then moves all points together along their own:
    x_i = p_i + s n_i minimising sum_j w_ij ((n_i + n_j) . (x_i - p_j))^2 over
    neighbours with n_i . n_j >= rho, w_ij Gaussian in |p_j - p_i| (1 l; 1.5 l
    after the first round), |s| <= max_step l (n_i + n_j keeps spheres and
    cylinders in place); a point with < 5 such neighbours takes their normals.
    Later rounds: PCA normals of moved points, planes 1.25 n_i + 0.75 n_j.

    Examples
    --------
    >>> from pointatlas.synth import plane_patch, add_normal_noise
    >>> m = plane_patch(16, 16)
    >>> noisy = add_normal_noise(m.points, m.normals, 0.3, rng=0)
    >>> r = normal_voting_denoise(noisy, m.normals)
    >>> bool(abs(r.points[:, 2]).mean() < abs(noisy[:, 2]).mean())
    True
    """
    pts, nrm, opt = _voting_options(
        points,
        normals,
        rho=rho,
        tau=tau,
        n_iter=n_iter,
        n_filter_iter=n_filter_iter,
        n_update=n_update,
        adaptive=adaptive,
        max_step=max_step,
        sharpen=sharpen,
        radius_factor=radius_factor,
        normal_k=normal_k,
        neighbors=neighbors,
        spacing=spacing,
        refit_normals=refit_normals,
    )
    with threads_for(pts.shape[0]):
        table, idx, k_def, ell = _neighbourhoods(
            pts,
            opt.pop("radius_factor"),
            K_WIDTH if opt["adaptive"] else 0,
            opt.pop("neighbors"),
            opt.pop("spacing"),
        )
        if nrm is None:
            nrm = _estimated_normals(pts, table, opt["normal_k"])
        cur, nrm, k_of, fallback, klass, ran = _rounds(
            pts, nrm, table, idx, k_def, ell, progress=progress, **opt
        )
    return _voting_result(pts, cur, nrm, k_of, fallback, klass, ran, ell, opt["adaptive"])


def _voting_result(pts, cur, nrm, k_of, fallback, klass, ran, ell, adaptive):
    """The `DenoiseResult` of `normal_voting_denoise` (non-finite points raise)."""
    if not np.isfinite(cur).all():
        raise PointAtlasError("normal voting denoising produced non-finite points")
    return DenoiseResult(
        points=cur.copy(),
        normals=nrm,
        displacement=np.sqrt(((cur - pts) ** 2).sum(axis=1)),
        feature_class=klass.astype(np.int8),
        energy=np.full(pts.shape[0], np.nan),
        k=k_of,
        method="normal-voting-adaptive" if adaptive else "normal-voting",
        n_iter=ran,
        n_fallback=int(fallback.sum()),
        spacing=ell,
    )


def _voting_options(
    points,
    normals,
    *,
    rho,
    tau,
    n_iter,
    n_filter_iter,
    n_update,
    adaptive,
    max_step,
    sharpen,
    radius_factor,
    normal_k,
    neighbors,
    spacing,
    refit_normals,
):
    """Validated input of `normal_voting_denoise`: (points, normals or None, options).

    The options are the keywords of `_rounds` plus ``radius_factor``,
    ``neighbors`` (a checked table or None) and ``spacing`` (or None).
    """
    pts, nrm, rho, tau, radius_factor = _check_common(
        points, normals, rho, tau, radius_factor, optional=True
    )
    n = pts.shape[0]
    adaptive = bool(adaptive)
    if spacing is not None:
        spacing = as_float(spacing, "spacing", lo=0.0, lo_open=True)
    refit = nrm is None if refit_normals is None else bool(refit_normals)
    if n_filter_iter is None:
        n_filter_iter = default_filter_iter(refit)
    opt = {
        "rounds": MAX_ROUNDS if n_iter is None else as_iterations(n_iter, "n_iter", _ROUND),
        "auto": n_iter is None,
        "rho": rho,
        "tau": tau,
        "n_filter_iter": as_iterations(n_filter_iter, "n_filter_iter", _STEP),
        "n_update": None if n_update is None else as_int(n_update, "n_update", lo=0),
        "adaptive": adaptive,
        "max_step": as_float(max_step, "max_step", lo=0.0),
        "sharpen": bool(sharpen),
        "normal_k": min(as_int(normal_k, "normal_k", lo=3), n),
        "refit": refit,
        "radius_factor": radius_factor,
        "neighbors": None if neighbors is None else check_table(neighbors, n, adaptive),
        "spacing": spacing,
    }
    return pts, nrm, opt
