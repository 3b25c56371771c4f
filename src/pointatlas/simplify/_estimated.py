"""`simplify_points` on estimated normals, estimated again where the output misses
the points (`simplify_estimated`). Decisions: docs/decisions/simplify.md ("Normals
for raw points", the second estimate).
"""

from __future__ import annotations

import warnings
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from .._core import as_int, readonly
from ._decimate_mesh import MAX_ERROR
from ._pipeline import PointSimplification, simplify_points

__all__ = ["RETRY_FACTOR", "RETRY_K", "EstimatedSimplification", "simplify_estimated"]

#: The normals are estimated again where the output lies farther from the points
#: (two-sided, as reported) than this many times the bound (the one asked, at least
#: the default `MAX_ERROR` of the diagonal): there the points' surface itself missed
#: the bound, which the decimation keeps to wherever that surface reaches it (not
#: where strays were left out, nor where the output is open: the report is then the
#: strays' left in, or the outline's and the gaps'; every 6th model with 1 % of the
#: points moved off: 19 of 25 past it; from one view: 8, the outputs kept at most
#: 0.15 % of the diagonal nearer, the truth within 1 % on 13 / 25 either way) ...
RETRY_FACTOR = 2.0
#: ... at these neighbourhood sizes in turn (but the first's, and those over the
#: number of points), until a closed output comes within that distance, and the
#: output nearest to the points kept (the first on a tie). All 149 collection models
#: sampled with 20,000 points, normals estimated at k = 20: 17 closed outputs past 1 %
#: of the diagonal; with k = 30 and 40 tried there, 8 of them within 1 % (k = 30
#: alone 4, 40 alone 5, 12 and 30 5; docs/decisions/simplify.md).
RETRY_K = (30, 40)


@dataclass(frozen=True, slots=True)
class EstimatedSimplification:
    """Result of `simplify_estimated`.

    Attributes
    ----------
    result : PointSimplification
        The kept run of `simplify_points`.
    normals : ndarray of shape (N, 3), float64
        The normals it was given (estimated at ``k``).
    k : int
        The neighbourhood size of those normals.
    tried : tuple of (int, float)
        Each run's neighbourhood size and two-sided distance to the points (input
        units), in the order run: one entry where the first output is near enough,
        two where the first size of `RETRY_K` tried comes near enough.
    """

    result: PointSimplification
    normals: np.ndarray
    k: int
    tried: tuple

    def __post_init__(self) -> None:
        readonly(self.normals)


def two_sided(result: PointSimplification) -> float:
    """The output's two-sided distance to the points, as reported (input units):
    the larger of the points' distance to it and its samples' to the points."""
    return float(result.mesh.hausdorff)


def retry_over(result: PointSimplification, points, max_error: float | None) -> float:
    """The distance past which `simplify_estimated` estimates again: `RETRY_FACTOR`
    times the bound, at least the default one (`MAX_ERROR` of the diagonal of the
    points used)."""
    used = np.asarray(points, dtype=np.float64)[result.point_index]
    diag = float(np.linalg.norm(np.ptp(used, axis=0))) if used.size else 0.0
    bound = MAX_ERROR * diag
    if max_error is not None:
        bound = max(bound, float(max_error))
    return RETRY_FACTOR * bound


def simplify_estimated(
    points,
    estimate: Callable[[int], np.ndarray],
    *,
    normal_k: int = 20,
    normals=None,
    on_retry: Callable[[float, tuple], None] | None = None,
    **kwargs,
) -> EstimatedSimplification:
    """Simplify points whose normals are estimated, estimating them again where the
    output misses the points.

    `simplify_points` runs on the normals estimated at ``normal_k``; where its output
    lies farther from the points than `RETRY_FACTOR` times the bound (both ways, as
    reported), the normals are estimated again at each size of `RETRY_K` in turn,
    until a closed output comes within that distance, and the closed output nearest
    to the points is kept. Estimated normals go wrong beside edges and thin walls, in
    ways that change with the neighbourhood's size; the points say which surface fits
    them. Not with a triangle budget (``max_triangles``: the budget, not the normals,
    sets the distance), nor where points were left out far off the surface
    (``n_off_surface``: the strays nearer than those set it), nor where the first
    output is open (a scan of one side: its outline and gaps set it).

    Parameters
    ----------
    points : array_like of shape (N, 3), float64
        Coordinates.
    estimate : callable
        ``estimate(k)`` returns the points' oriented normals (N, 3) estimated with
        neighbourhoods of ``k`` (e.g. `surface_normals`, oriented, then
        `sharpen_normals` and `outward_normals`, as ``pointatlas simplify`` does).
    normal_k : int
        The first estimate's neighbourhood size.
    normals : array_like of shape (N, 3), float64, optional
        The first estimate, where already made (else ``estimate(normal_k)``).
    on_retry : callable, optional
        Called as ``on_retry(distance, sizes)`` before the normals are estimated
        again (the first output's distance, the sizes to try in turn): a progress
        line.
    **kwargs
        Passed to `simplify_points`.

    Returns
    -------
    EstimatedSimplification
        The kept run, its normals and size, and every run's size and distance. The
        kept run's warnings are given again; the others' are not.

    Examples
    --------
    >>> from pointatlas.synth import cube
    >>> m = cube(6)
    >>> out = simplify_estimated(m.vertices, lambda k: m.normals, max_angle=0.3)
    >>> out.k, out.result.mesh.n_faces, len(out.tried)
    (20, 6, 1)
    """
    normal_k = as_int(normal_k, "normal_k", lo=1)
    first = np.asarray(estimate(normal_k) if normals is None else normals, dtype=np.float64)
    runs = [(normal_k, first, *_run(points, first, kwargs))]
    tried = [(normal_k, two_sided(runs[0][2]))]
    n_points = np.asarray(points).shape[0]
    sizes = tuple(k for k in RETRY_K if k != normal_k and k <= n_points)
    over = retry_over(runs[0][2], points, kwargs.get("max_error"))
    # not where strays left in or an open outline set the distance
    first_run = runs[0][2]
    surface_miss = first_run.n_off_surface == 0 and first_run.mesh.is_closed
    if tried[0][1] > over and surface_miss and kwargs.get("max_triangles") is None and sizes:
        if on_retry is not None:
            on_retry(tried[0][1], sizes)
        for k in sizes:
            n = np.asarray(estimate(k), dtype=np.float64)
            runs.append((k, n, *_run(points, n, kwargs)))
            tried.append((k, two_sided(runs[-1][2])))
            if tried[-1][1] <= over and runs[-1][2].mesh.is_closed:
                break  # near enough: the next size is not asked
    # the nearest of the first and the later closed outputs (the first is closed where
    # they ran: another estimate may open the surface)
    kept = [0] + [i for i in range(1, len(runs)) if runs[i][2].mesh.is_closed]
    best = min(kept, key=lambda i: (tried[i][1], i))
    k, n, result, caught = runs[best]
    for w in caught:  # the kept run's warnings only
        warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)
    return EstimatedSimplification(result, n.copy(), k, tuple(tried))


def _run(points, normals, kwargs: dict) -> tuple:
    """`simplify_points` and the warnings it gave (recorded, not shown)."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        result = simplify_points(points, normals, **kwargs)
    return result, list(caught)
