"""One entry point over the denoisers, and the choice of ``method="auto"``."""

from __future__ import annotations

import dataclasses

import numpy as np

from .._core import as_points, check_neighbors
from .._core.tolerances import DENOISE_K_MAX, DENOISE_K_MIN, DENOISE_K_WIDTH
from ..neighbors import query_knn
from ._flatness import flatness_denoise
from ._kernels import CLASS_FACE
from ._planes import PIECE_SEED, snap_to_pieces
from ._result import DenoiseResult
from ._sides import two_sides
from ._threads import threads_for
from ._voting import normal_voting_denoise

#: flatness_denoise's default k (a side needs more points to run apart)
FLATNESS_K = 28

__all__ = [
    "DENOISE_METHODS",
    "choose_method",
    "denoise",
    "flatness_with_sides",
    "snap_planar_pieces",
    "voting_with_pieces",
]

#: the methods of `denoise` (and ``pointatlas denoise --method``)
DENOISE_METHODS = ("normal-voting", "normal-voting-adaptive", "flatness", "auto")


def choose_method(points, normals=None) -> str:
    """The method ``"auto"`` runs on these inputs.

    Parameters
    ----------
    points : array_like of shape (N, 3), float64
        Noisy positions.
    normals : array_like of shape (N, 3), float64, optional
        Oriented normals, if any (without them normal voting estimates PCA normals).

    Returns
    -------
    method : str
        ``"normal-voting"``: in our benchmark it and the adaptive variant beat every
        peer in Chamfer and point-to-mesh distance on all inputs, by about the
        same margins, and the fixed neighbourhoods are faster (1.5-2.75x Open3D
        MLS's time against 2.1-3.6x for the adaptive k; docs/benchmarks.md,
        docs/decisions/denoise.md, "auto"). Flatness (Eq. 6.3) is the thesis'
        experiment, not a default.

    Examples
    --------
    >>> choose_method([[0, 0, 0]] * 3)
    'normal-voting'
    """
    as_points(points)
    return "normal-voting"


def denoise(
    points, normals=None, *, method: str = "auto", planes: bool = True, progress=None
) -> DenoiseResult:
    """Denoise a point set with one of `DENOISE_METHODS` at its default parameters.

    Parameters
    ----------
    points : array_like of shape (N, 3), float64
        Noisy positions.
    normals : array_like of shape (N, 3), float64, optional
        Oriented normals. Normal voting estimates PCA normals (k = 20, MST
        orientation) when None; flatness only uses them to sign its normals.
    method : str
        ``"normal-voting"`` (fixed [YRS+18] neighbourhoods), ``"normal-voting-adaptive"``
        (k by least E_dim, thesis 5.4), ``"flatness"`` (Eq. 6.3, k = 28, eta = 1,
        at most 60 iterations, stopped once the points moved about the noise) or
        ``"auto"`` (`choose_method`). On a thin plate (heights over the first
        result that are two sheets) the sides run apart (`two_sides`,
        docs/decisions/denoise.md, "Thin plates").
    planes : bool
        Normal voting: after the local denoise, group the points into planar
        pieces of at least 150 points; their points take the piece's plane
        normal and move onto the plane (`snap_planar_pieces`). Ignored by flatness.
    progress : callable, optional
        Called with 1 after every iteration step.

    Returns
    -------
    result : DenoiseResult
        The denoised points and per-point details.

    Raises
    ------
    ValueError
        Unknown method, bad input.

    Examples
    --------
    >>> from pointatlas.synth import plane_patch, add_normal_noise
    >>> m = plane_patch(12, 12)
    >>> noisy = add_normal_noise(m.points, m.normals, 0.3, rng=0)
    >>> denoise(noisy, m.normals).method
    'normal-voting'
    """
    if method not in DENOISE_METHODS:
        raise ValueError(f"method must be one of {', '.join(DENOISE_METHODS)}; got {method!r}")
    if method == "auto":
        method = choose_method(points, normals)
    if method == "flatness":
        return flatness_with_sides(points, normals, progress=progress)
    return voting_with_pieces(
        points,
        normals,
        planes=planes,
        adaptive=method == "normal-voting-adaptive",
        progress=progress,
    )


def voting_with_pieces(
    points, normals=None, *, planes: bool = True, neighbors=None, **options
) -> DenoiseResult:
    """`normal_voting_denoise` with ``options``, then (``planes``) `snap_planar_pieces`.

    Parameters
    ----------
    points : array_like of shape (N, 3), float64
        Noisy positions.
    normals : array_like of shape (N, 3), float64, optional
        Oriented normals (None: estimated by normal voting).
    planes : bool
        Run the planar pieces after the local denoise (the default of `denoise`
        and ``pointatlas denoise``).
    neighbors : array_like of shape (N, m), int, optional
        The input's k-NN rows (the point first), at least min(48 (+10 adaptive), N)
        columns, the first of which are used, e.g. a tile's exact table; None:
        queried here.
    **options
        Keywords of `normal_voting_denoise` (``rho``, ``tau``, ``n_iter``,
        ``adaptive``, ``spacing``, ``progress``, ...).

    Returns
    -------
    result : DenoiseResult
        As `normal_voting_denoise`, with the pieces' points and normals.

    Notes
    -----
    One k-NN table of the input, min(48 (+10 adaptive), N) columns, serves both:
    it is the table normal voting would query itself (the same result bit for bit).
    """
    pts = as_points(points, min_points=DENOISE_K_MIN + 1)
    n = pts.shape[0]
    width = DENOISE_K_MAX + (DENOISE_K_WIDTH if options.get("adaptive") else 0)
    # one thread for small inputs on a busy machine (_threads.py), also for the query
    with threads_for(n):
        if neighbors is None:
            table = query_knn(pts, min(width, n))[0]
        else:
            table = check_neighbors(neighbors, n, k=min(width, n))
        result = normal_voting_denoise(pts, normals, neighbors=table, **options)
        side = two_sides(pts, result.points, result.normals, table, result.spacing)
        if side is not None:  # a thin plate: each side on its own, no pieces (merge up to sign)
            return _voting_sides(pts, normals, result, side, table, options)
        if not planes:
            return result
        return snap_planar_pieces(pts, result, neighbors=table)


def _voting_sides(pts, normals, first, side, table, options) -> DenoiseResult:
    """Normal voting again with the first run's normals signed by ``side`` (the
    planes then take only their own side); the returned normals keep the first
    run's orientation."""
    opts = dict(options)
    if opts.get("refit_normals") is None:
        opts["refit_normals"] = normals is None
    again = normal_voting_denoise(pts, first.normals * side[:, None], neighbors=table, **opts)
    flip = (again.normals * first.normals).sum(axis=1) < 0
    return dataclasses.replace(
        again, normals=np.where(flip[:, None], -again.normals, again.normals)
    )


def flatness_with_sides(points, normals=None, *, progress=None, **options) -> DenoiseResult:
    """`flatness_denoise` with ``options``; on a thin plate each side runs apart.

    Parameters
    ----------
    points : array_like of shape (N, 3), float64
        Noisy positions.
    normals : array_like of shape (N, 3), float64, optional
        Oriented normals (flatness only uses them to sign its own).
    progress : callable, optional
        Called with 1 after every iteration of the first run.
    **options
        Keywords of `flatness_denoise` (``k``, ``eta``, ``eps``, ``n_iter``,
        ``schedule``, ``k_start``, ...).

    Returns
    -------
    result : DenoiseResult
        As `flatness_denoise`; on a thin plate the points of each side are those of a
        run over that side alone.

    Notes
    -----
    The heights of the input over the first result are tested for two sheets
    (`two_sides`, docs/decisions/denoise.md, "Thin plates"): flatness pulls both
    sides of a plate thinner than about 3 noise sigmas onto its mid-plane. Each
    side then runs again on its own, when it has more points than ``k`` (and
    ``k_start``).

    Examples
    --------
    >>> from pointatlas.synth import plane_patch, add_normal_noise
    >>> m = plane_patch(12, 12)
    >>> noisy = add_normal_noise(m.points, m.normals, 0.3, rng=0)
    >>> flatness_with_sides(noisy, k=14).points.shape
    (144, 3)
    """
    first = flatness_denoise(points, normals=normals, progress=progress, **options)
    pts = as_points(points)
    n = pts.shape[0]
    with threads_for(n):
        table = query_knn(pts, min(DENOISE_K_MAX, n))[0]
        side = two_sides(pts, first.points, first.normals, table, first.spacing)
    k = max(options.get("k") or FLATNESS_K, options.get("k_start") or 0)
    if side is None or min((side > 0).sum(), (side < 0).sum()) <= k:
        return first
    out = np.empty_like(pts)
    energy = np.empty(n)
    for s in (1.0, -1.0):
        part = side == s
        given = None if normals is None else first.normals[part]
        r = flatness_denoise(pts[part], normals=given, **options)
        out[part], energy[part] = r.points, r.energy
    return dataclasses.replace(
        first, points=out, energy=energy, displacement=np.sqrt(((out - pts) ** 2).sum(axis=1))
    )


def snap_planar_pieces(points, result: DenoiseResult, *, neighbors=None) -> DenoiseResult:
    """A normal voting result whose points on planar pieces take the piece's plane.

    Parameters
    ----------
    points : array_like of shape (N, 3), float64
        The input of the denoise (the displacement is measured from it).
    result : DenoiseResult
        A `normal_voting_denoise` result (its points, normals, classes and l).
    neighbors : array_like of shape (N, K), int, optional
        The input's k-NN table (each row its point first, then by distance),
        K >= 25, as `normal_voting_denoise` took it: the growth graph (points
        moved by less than l). None: queried on the denoised points.

    Returns
    -------
    result : DenoiseResult
        The same with new ``points``, ``normals`` and ``displacement`` (from the
        same input positions; everything else unchanged).

    Raises
    ------
    ValueError
        ``points`` not of the result's shape, a bad ``neighbors`` table.

    Notes
    -----
    The global step between the local denoise and the output
    (docs/decisions/denoise.md, "Planar pieces"): pieces start at the flattest
    face-class points and grow over the 12 nearest neighbours through points within
    0.4 l of a fixed plane whose normal is within 10 degrees of it; the plane is refitted
    to the members twice (regrowing each time) and a piece of at least 150 points is
    kept. Each point then takes, signed like its own, the normal of the nearest
    piece plane among its neighbours' pieces when within 0.4 l, its normal within
    7 degrees (15 when the denoise ran several rounds: about 1 l of noise) and no
    second plane within 0.75 l, and moves onto that plane.

    Examples
    --------
    >>> from pointatlas.synth import cube
    >>> from pointatlas.denoise import add_noise
    >>> m = cube(16)
    >>> noisy = add_noise(m.points, m.normals, 0.3, k=6, rng=0)
    >>> r = snap_planar_pieces(noisy, normal_voting_denoise(noisy, None))
    >>> bool(np.abs(np.abs(r.points).max(axis=1) - 0.5).mean() < 0.01)
    True
    """
    start = as_points(points)
    if start.shape != result.points.shape:
        raise ValueError(
            f"points must have the result's shape {result.points.shape}; got {start.shape}"
        )
    if result.n_iter == 0:
        return result
    pts = result.points
    with threads_for(pts.shape[0]):
        table = None
        if neighbors is not None:
            table = check_neighbors(neighbors, pts.shape[0], k=min(PIECE_SEED, pts.shape[0]))
        normals, moved, _ = snap_to_pieces(
            pts,
            result.normals,
            result.feature_class == CLASS_FACE,
            result.spacing,
            high_noise=result.n_iter > 1,
            table=table,
        )
    return dataclasses.replace(
        result,
        points=moved,
        normals=normals,
        displacement=np.sqrt(((moved - start) ** 2).sum(axis=1)),
    )
