"""Oriented normals made sharp beside edges and thin walls (private; public as
`sharpen_normals`).

A PCA normal over a neighbourhood that crosses an edge blends the faces' normals:
near the edge it points between them, and a point on one face whose neighbours are
mostly on the other gets the other face's normal (a few percent of a sampled CAD
part's points more than 60 degrees off their face's normal). The points path's
field takes the sign of its nodes from those tangent planes, and such normals
bridge thin walls and edges with small handles: the estimated normals' surfaces
missed the Euler characteristic on 35 of the 149 collection models where the true
normals missed it on 9, and on 6 of 8 of those the true normals at the points
more than 60 degrees off, given alone, gave it back. Here, at each point whose
neighbourhood is not flat, planes through the point and two of its nearest
neighbours are scored by the neighbours within a tolerance of them, less those on
the plane's lesser side (a chord across a small cylinder or a slot has points on
both sides; a face beside an edge has the other face on one side only); the best,
refitted to the neighbours on it, replaces the blended normal where it holds more
of them, unless a quadric height over the given normal's plane fits the
neighbourhood within the spacings' tolerance: a smooth curve, where a chord plane
through two rows of a coarsely sampled tube holds more neighbours than the tangent
plane (within the noise's tolerance a noisy quadric takes an edge's crease in
too). The sign is the oriented normal's where the two agree, and elsewhere that of
the neighbours already signed on the same plane (not across a thin wall: a neighbour
off the plane does not vote). The noise floor that gates it is at most
`_normals.NOISE_CORE_RATIO` times the floor of the smallest neighbourhoods: both
sides of a thin wall in a neighbourhood of 10 are not noise. Decisions:
docs/decisions/simplify.md, "Normals for raw points".
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from .._core import as_k, as_normals, as_points
from ..neighbors import query_knn
from ._normals import FLAT_VARIATION, NORMAL_K_RANGE, bent_beyond_noise

__all__ = [
    "PAIR_NEIGHBORS",
    "PLANE_SPACINGS",
    "QUADRIC_NEIGHBORS",
    "SIGN_AGREE",
    "SIGN_SAME",
    "sharpen_normals",
]

#: Planes through the point and two of its this many nearest (itself counted) ...
PAIR_NEIGHBORS = 10
#: ... hold a neighbour within this many point spacings (median nearest-neighbour
#: distance; or three times the noise's deviation where that is more).
PLANE_SPACINGS = 0.2
#: A neighbourhood of at least this many points (itself counted) that a quadric
#: height over the given normal's plane fits within `PLANE_SPACINGS` point spacings
#: (not the noise's tolerance) is smooth (a cylinder, a sphere, a fillet): its
#: normal stays.
QUADRIC_NEIGHBORS = 12
#: The sharp normal takes the oriented one's sign where their directions agree this
#: well (|cos|) ...
SIGN_AGREE = 0.8
#: ... elsewhere that of the neighbours signed already whose normals lie this near its
#: line (|cos|) and which lie on its plane.
SIGN_SAME = 0.9


@njit(cache=True)
def _score(n, rel, tau):
    """Neighbours ``rel`` (offsets from the point) within ``tau`` of the plane of
    normal ``n`` through the point, less those on its lesser side."""
    on = 0
    above = 0
    below = 0
    for k in range(rel.shape[0]):
        d = n[0] * rel[k, 0] + n[1] * rel[k, 1] + n[2] * rel[k, 2]
        if d > tau:
            above += 1
        elif d < -tau:
            below += 1
        else:
            on += 1
    return on - min(above, below)


@njit(cache=True)
def _smooth(n, rel, tau, fewest):
    """Whether the height over the plane of normal ``n`` of the neighbours ``rel``
    (offsets from the point; at least ``fewest`` of them, and more than the
    quadric's six coefficients) is a quadric in the plane's coordinates to within
    ``tau`` (least squares, in units of the farthest neighbour's distance)."""
    m = rel.shape[0]
    scale = 0.0
    for k in range(m):
        scale = max(scale, np.sqrt((rel[k] ** 2).sum()))
    if m < max(fewest, 7) or scale <= 0.0:
        return False
    a = np.array([1.0, 0.0, 0.0]) if abs(n[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    u = np.cross(n, a)
    u /= np.sqrt((u**2).sum())
    v = np.cross(n, u)
    design = np.empty((m, 6))
    height = np.empty(m)
    for k in range(m):
        x = (rel[k, 0] * u[0] + rel[k, 1] * u[1] + rel[k, 2] * u[2]) / scale
        y = (rel[k, 0] * v[0] + rel[k, 1] * v[1] + rel[k, 2] * v[2]) / scale
        height[k] = (rel[k, 0] * n[0] + rel[k, 1] * n[1] + rel[k, 2] * n[2]) / scale
        design[k, 0] = x * x
        design[k, 1] = x * y
        design[k, 2] = y * y
        design[k, 3] = x
        design[k, 4] = y
        design[k, 5] = 1.0
    coef = np.linalg.lstsq(design, height)[0]
    return np.abs(design @ coef - height).max() <= tau / scale


@njit(cache=True)
def _refit(n, rel, tau):
    """The plane of the neighbours within ``tau`` of the plane ``n``, refitted
    (their covariance's least eigenvector); ``n`` where they are fewer than six or
    lie about a line."""
    on = np.zeros(rel.shape[0], dtype=np.bool_)
    count = 0
    for k in range(rel.shape[0]):
        d = n[0] * rel[k, 0] + n[1] * rel[k, 1] + n[2] * rel[k, 2]
        if abs(d) <= tau:
            on[k] = True
            count += 1
    if count < 6:
        return n
    sel = rel[on]
    c = sel - sel.sum(axis=0) / count
    w, v = np.linalg.eigh(c.T @ c)
    if w[1] <= 0.1 * w[2]:
        return n
    return v[:, 0].copy()


@njit(cache=True, parallel=True)
def _plane_normals(pts, idx, rows, normals, tau, pairs, fewest, fit_tau):
    """For each row ``rows[r]`` (a point whose neighbourhood is not flat), the best
    scoring plane through it and two of its ``pairs`` nearest (`_score`), refitted
    (`_refit`), where it scores above the plane of its normal and the neighbourhood
    is not a smooth quadric over that plane (`_smooth`: within ``fit_tau``, with
    ``fewest`` neighbours or more): ``(sharp, took)``.
    Assumes validated input: ``idx`` rows nearest first, the point itself first."""
    out = np.empty((rows.size, 3))
    took = np.zeros(rows.size, dtype=np.bool_)
    m = min(pairs, idx.shape[1])
    for r in prange(rows.size):
        i = rows[r]
        rel = pts[idx[i]] - pts[i]
        out[r] = normals[i]
        if _smooth(normals[i], rel, fit_tau, fewest):
            continue
        own = _score(normals[i], rel, tau)
        best = own
        n = normals[i].copy()
        for a in range(1, m):
            la = np.sqrt((rel[a] ** 2).sum())
            for b in range(a + 1, m):
                c = np.cross(rel[a], rel[b])
                ln = np.sqrt((c**2).sum())
                # nearly on one line with the point: no plane
                if ln <= 0.2 * la * np.sqrt((rel[b] ** 2).sum()):
                    continue
                c = c / ln
                s = _score(c, rel, tau)
                if s > best:
                    best, n = s, c
        if best > own:
            out[r] = _refit(n, rel, tau)
            took[r] = True
    return out, took


def _signs(pts, sharp, oriented, idx, tau):
    """+-1 per point: the sign that turns ``sharp`` to agree with ``oriented`` where
    their lines agree (`SIGN_AGREE`), then, repeatedly, the vote of the neighbours
    signed already on the point's plane with a normal on its line (`SIGN_SAME`);
    the few left: the mean oriented normal of their neighbours."""
    d = np.einsum("ij,ij->i", sharp, oriented)
    sign = np.where(np.abs(d) >= SIGN_AGREE, np.sign(d), 0.0)
    for _ in range(idx.shape[1]):
        left = np.flatnonzero(sign == 0.0)
        if left.size == 0:
            break
        nb = idx[left]
        lines = np.einsum("ud,ukd->uk", sharp[left], sharp[nb])
        off = np.abs(np.einsum("ud,ukd->uk", sharp[left], pts[nb] - pts[left][:, None]))
        votes = np.where((np.abs(lines) >= SIGN_SAME) & (off <= tau), np.sign(lines), 0.0)
        new = np.sign((votes * sign[nb]).sum(axis=1))
        if not new.any():
            break
        sign[left] = new
    left = sign == 0.0
    if left.any():
        mean = oriented[idx[left]].sum(axis=1)
        sign[left] = np.where(np.einsum("ij,ij->i", sharp[left], mean) < 0.0, -1.0, 1.0)
    return sign


def sharpen_normals(points, normals, k: int = 20, *, neighbors=None) -> np.ndarray:
    """Oriented normals of a point set, sharp beside its edges and thin walls.

    Where a point's ``k``-neighbourhood is not flat (surface variation above
    `FLAT_VARIATION`, and bent beyond the noise: `surface_normals`' test,
    `_normals.bent_beyond_noise`), its normal becomes that of the plane through it and two of its
    `PAIR_NEIGHBORS` nearest which holds the most of its neighbours within
    `PLANE_SPACINGS` point spacings (less those on the plane's lesser side),
    refitted to them, where that plane holds more than the given normal's and no
    quadric height over the given normal's plane fits the neighbourhood within
    `PLANE_SPACINGS` point spacings (`QUADRIC_NEIGHBORS` points or more); the signs
    follow the given orientation (see the module's notes).

    Parameters
    ----------
    points : array_like of shape (N, 3)
        Coordinates, finite.
    normals : array_like of shape (N, 3)
        Oriented unit normals (`surface_normals` then
        `pointatlas.normals.orient_normals`).
    k : int
        Neighbourhood size (the point itself included; 3 <= k <= N).
    neighbors : ndarray of shape (N, m), int, or tuple, optional
        `pointatlas.neighbors.query_knn`'s ``(indices, distances)`` with at least
        ``k`` columns, itself first; searched when None or an index array alone.

    Returns
    -------
    normals : ndarray of shape (N, 3), float64
        Unit normals, oriented as ``normals``.

    Raises
    ------
    ValueError
        If ``normals`` is not one unit row per point, or ``k`` is outside 3..N.
    NonFiniteError
        If ``points`` or ``normals`` hold NaN or Inf.

    Examples
    --------
    >>> from pointatlas.simplify import surface_normals
    >>> rng = np.random.default_rng(0)
    >>> top = np.c_[rng.random((300, 2)), np.ones(300)]
    >>> side = np.c_[rng.random(300), np.ones(300), rng.random(300)]
    >>> pts = np.vstack([top, side])  # two faces meeting at an edge
    >>> blended = surface_normals(pts)
    >>> blended *= np.sign(blended @ [0.0, 1.0, 1.0])[:, None]  # outward
    >>> true = np.repeat([[0.0, 0.0, 1.0], [0.0, 1.0, 0.0]], 300, axis=0)
    >>> def off(n):  # normals more than 30 degrees off their face's
    ...     return int((np.abs((n * true).sum(axis=1)) < np.cos(np.radians(30))).sum())
    >>> off(blended), off(sharpen_normals(pts, blended))
    (13, 3)
    """
    pts = as_points(points)
    n = pts.shape[0]
    nrm = as_normals(normals, n, normalize=False)
    k = as_k(k, n, minimum=3)
    if not isinstance(neighbors, tuple) or neighbors[0].shape[1] < k:
        neighbors = query_knn(pts, k)
    idx = np.ascontiguousarray(neighbors[0][:, :k], dtype=np.int64)
    small = min(k, NORMAL_K_RANGE[0])
    _, bent, floor = bent_beyond_noise(pts, idx, k, FLAT_VARIATION, small, core=True)
    spacing = float(np.median(neighbors[1][:, 1])) if k > 1 else 0.0
    tau = max(PLANE_SPACINGS * spacing, 3.0 * np.sqrt(max(floor, 0.0)))
    # the quadric within the spacings' tolerance alone: within the noise's, a noisy
    # neighbourhood's quadric takes an edge's crease in too
    fit_tau = PLANE_SPACINGS * spacing
    out = nrm.copy()
    rows = np.flatnonzero(bent)
    if rows.size:
        out[rows] = _plane_normals(
            pts, idx, rows, nrm, tau, PAIR_NEIGHBORS, QUADRIC_NEIGHBORS, fit_tau
        )[0]
    return out * _signs(pts, out, nrm, idx, tau)[:, None]
