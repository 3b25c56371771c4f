"""Normal voting denoising [YRS+18] (thesis 5.4): rounds of the normal filter
(`_filter`) and the point update, the driver `normal_voting_denoise`."""

from __future__ import annotations

import numpy as np

from .._core import (
    PointAtlasError,
    as_float,
    as_int,
    as_iterations,
    readonly_view,
)
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
from ._filter import (
    _STEP,
    K_WIDTH,
    _check_common,
    _estimated_normals,
    _filter_steps,
    _neighbourhoods,
)
from ._kernels import (
    face_normals_kernel,
    feature_class_kernel,
    lonely_normals_kernel,
    plane_lists_kernel,
    plane_update_kernel,
    polish_kernel,
)
from ._result import DenoiseResult
from ._sharpen import quadric_update_kernel
from ._tables import check_table
from ._threads import threads_for

__all__ = ["normal_voting_denoise"]

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


_ROUND = "each round is a pass over every point"


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
