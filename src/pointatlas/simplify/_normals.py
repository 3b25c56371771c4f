"""Unoriented normals for the points path, where the input has none (private; public
as `surface_normals`).

PCA over a fixed k = 20 blends the two sides of a wall a few point spacings thick and
the faces beside an edge: those normals bridge thin walls with handles on the
voxel surface (docs/decisions/simplify.md, "Normals turned to the outside"). Where a
point's k-neighbourhood is not flat, its normal here is instead that of the
neighbourhood size that minimises the eigenentropy (Weinmann et al., the thesis'
optimal neighbourhoods, `pointatlas.features.optimal_k_features`): near a thin wall
or an edge a smaller neighbourhood of the point's own face is the more ordered one.
Flat neighbourhoods keep the k-NN normal (with noise a smaller k only adds it), and
so do those bent no more than noise bends them: under a scanner's noise nearly every
neighbourhood reads as not flat, and the least-entropy sizes follow the noise.
Where what reads as noise is walls thinner than the sampling (a tube whose wall is
one point spacing thick: both sides in every neighbourhood), those bent neighbourhoods
take the largest size's normal instead, which reaches farther along the wall than
across it. Decisions: docs/decisions/simplify.md, "Normals for raw points".
"""

from __future__ import annotations

import numpy as np

from .._core import as_points
from ..features import optimal_k_features
from ..neighbors import query_knn
from ..normals import pca_normals
from ._checks import distinct_positions

__all__ = [
    "FLAT_VARIATION",
    "NOISE_CORE_K",
    "NOISE_CORE_RATIO",
    "NOISE_FACTOR",
    "NOISE_SAMPLE",
    "NORMAL_K_RANGE",
    "bent_beyond_noise",
    "noise_floor",
    "surface_normals",
]

#: A neighbourhood is flat where its surface variation, lambda_3 / (lambda_1 +
#: lambda_2 + lambda_3) at k, is at most this (a plane sampled without noise: 0;
#: beside an edge or across a thin wall: up to 1/3).
FLAT_VARIATION = 0.02
#: Neighbourhood sizes searched where it is not flat (the point itself counted).
NORMAL_K_RANGE = (10, 30)
#: ... and only where its smallest covariance eigenvalue at k passes this many times
#: the noise's: the first quartile of that eigenvalue over neighbourhoods of the
#: smallest size searched (noise gives a small neighbourhood the variance a larger
#: one has; a curved surface or an edge, a smaller one: clean samples of every
#: collection model but three whose every neighbourhood is bent keep all of theirs) ...
NOISE_FACTOR = 8.0
#: ... measured on every s-th point, s the smallest stride leaving at most this many.
NOISE_SAMPLE = 20_000
#: That floor is at most `NOISE_CORE_RATIO` times the floor of the smallest
#: neighbourhoods (this many points): on planes with Gaussian noise of 0.3-2.8
#: spacings the floor at 10 is 2.6-4.3 times the floor at 6; more is both sides of a
#: thin wall in the larger neighbourhoods, not noise (a tube whose wall is 2.1
#: spacings thick: 0.59 spacings at 10, 0.027 at 6) ...
NOISE_CORE_K = 6
#: ... and this ratio.
NOISE_CORE_RATIO = 4.5


def surface_normals(
    points, k: int = 20, *, k_range=NORMAL_K_RANGE, flat: float = FLAT_VARIATION, neighbors=None
) -> np.ndarray:
    """Unoriented normals of a point set for `simplify_points`.

    The PCA normal of the ``k`` nearest points where their surface variation is at
    most ``flat``; elsewhere (edges, corners, thin walls) the normal of the
    neighbourhood size in ``k_range`` with the least eigenentropy, unless the
    neighbourhood is bent no more than noise bends it (its smallest covariance
    eigenvalue at most `NOISE_FACTOR` times `noise_floor`'s); those bent no more
    than noise take the PCA normal at ``k_range[1]`` where the noise is walls
    thinner than the sampling (`_across_thin_walls`).

    Parameters
    ----------
    points : array_like of shape (N, 3)
        Coordinates, finite.
    k : int
        Neighbourhood size of the flat test and of the flat points' normals (the
        point itself included; 3 <= k <= N).
    k_range : tuple of int
        Inclusive range of the sizes searched elsewhere (clipped to N).
    flat : float
        Largest surface variation, lambda_3 / (lambda_1 + lambda_2 + lambda_3), of a
        flat neighbourhood.
    neighbors : ndarray of shape (N, m), int, or tuple, optional
        Neighbour table sorted by distance, itself first, or
        `pointatlas.neighbors.query_knn`'s tuple; with fewer than max(k,
        k_range[1]) columns (or None) one such query is made.

    Returns
    -------
    normals : ndarray of shape (N, 3), float64
        Unit normals with arbitrary sign (orient them with
        `pointatlas.normals.orient_normals`). Points at one position share the
        normal estimated for it among the distinct positions (``neighbors`` is then
        not used): copies would fill a neighbourhood with one position.

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> plane = np.c_[rng.random((200, 2)), np.zeros(200)]
    >>> np.abs(surface_normals(plane)[:, 2]).min().round(6)
    np.float64(1.0)
    """
    pts = as_points(points)
    first, inverse = distinct_positions(pts)
    if first.size < pts.shape[0]:  # each position once: the copies take its normal
        return surface_normals(pts[first], k, k_range=k_range, flat=flat)[inverse]
    n = pts.shape[0]
    lo, hi = min(int(k_range[0]), n), min(int(k_range[1]), n)
    width = min(max(int(k), hi), n)
    idx = None
    if neighbors is not None:
        idx = np.asarray(neighbors[0] if isinstance(neighbors, tuple) else neighbors)
    if idx is None or idx.shape[1] < width:  # too few columns: searched
        idx = query_knn(pts, width)[0]
    res, bent, floor = bent_beyond_noise(pts, idx, k, flat, lo)
    normals = np.array(res.normals)
    wide = _across_thin_walls(pts, idx, res.eigenvalues, bent, flat, floor, lo)
    if wide.any():  # both sides of a wall in one neighbourhood: the wider one's plane
        normals[wide] = pca_normals(pts, hi, neighbors=idx).normals[wide]
    if not bent.any():
        return normals
    opt = optimal_k_features(pts, k_range=(lo, hi), neighbors=np.ascontiguousarray(idx[:, :hi]))
    other = np.asarray(opt.eigenvector_3)
    use = bent & (np.asarray(opt.k) > 0) & np.isfinite(other).all(axis=1)
    return np.where(use[:, None], other, normals)


def _across_thin_walls(points, idx, eigenvalues, bent, flat: float, floor: float, small: int):
    """Which points take the PCA normal of the largest neighbourhood searched: those
    whose neighbourhood is not flat (surface variation above ``flat``) but bent no
    more than the noise floor (``floor``, `noise_floor` at ``small``: not ``bent``),
    where that floor is more than `NOISE_CORE_RATIO` times the floor of the smallest
    neighbourhoods (`NOISE_CORE_K` points): no noise, but walls thinner than the
    sampling, both of whose sides fill every neighbourhood (a sampled tube whose wall
    is one point spacing thick: 1,329 of its 20,000 normals more than 30 degrees off
    at k = 20, 122 at 30; on a surface with noise the floors keep within that ratio
    and nothing changes). There a wider neighbourhood reaches farther along the wall
    than across it."""
    quiet = (_variation(eigenvalues) > flat) & ~bent
    if not quiet.any() or small <= NOISE_CORE_K:
        return np.zeros(points.shape[0], dtype=bool)
    core = noise_floor(points, idx[:, :NOISE_CORE_K])
    return quiet if floor > NOISE_CORE_RATIO * core else np.zeros(points.shape[0], dtype=bool)


def bent_beyond_noise(
    points: np.ndarray, idx: np.ndarray, k: int, flat: float, small: int, core: bool = False
):
    """``(pca, bent, floor)`` of validated ``points`` and their neighbour table
    ``idx`` (nearest first, at least ``k`` and ``small`` columns): `pca_normals` at
    ``k``, where the neighbourhood is not flat (surface variation above ``flat``)
    and bent beyond the noise (its smallest eigenvalue above `NOISE_FACTOR` times
    the noise floor), and that floor (`noise_floor` at ``small``, with ``core`` at
    most `NOISE_CORE_RATIO` times the floor at `NOISE_CORE_K`; 0 where nothing is
    bent: a flat sample needs none)."""
    res = pca_normals(points, k, neighbors=idx)
    lam = res.eigenvalues
    bent = _variation(lam) > flat
    floor = 0.0
    if bent.any():
        floor = noise_floor(points, idx[:, :small])
        if core and small > NOISE_CORE_K:  # a thin wall is not noise
            core_floor = noise_floor(points, idx[:, :NOISE_CORE_K])
            floor = min(floor, NOISE_CORE_RATIO * core_floor)
    return res, bent & (lam[:, 2] > NOISE_FACTOR * floor), floor


def _variation(eigenvalues: np.ndarray) -> np.ndarray:
    """Surface variation lambda_3 / (lambda_1 + lambda_2 + lambda_3) per row of
    covariance ``eigenvalues`` (the smallest last; 0 where they sum to 0)."""
    total = eigenvalues.sum(axis=1)
    return np.divide(eigenvalues[:, 2], total, out=np.zeros(total.size), where=total > 0.0)


def noise_floor(points: np.ndarray, neighbors: np.ndarray) -> float:
    """The first quartile of the smallest covariance eigenvalue (about the mean,
    divided by the size, as `pca_normals`'s) over the neighbourhoods ``neighbors``
    (rows of indices into ``points``, one per point) of every s-th point, s the
    smallest stride leaving at most `NOISE_SAMPLE`: about sigma^2 for a sample with
    Gaussian noise sigma, near 0 for a clean one with flat parts.

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> plane = np.c_[rng.random((4000, 2)), 0.01 * rng.standard_normal(4000)]
    >>> bool(1e-5 < noise_floor(plane, query_knn(plane, 10)[0]) < 1e-4)
    True
    """
    rows = neighbors[:: max(1, -(-neighbors.shape[0] // NOISE_SAMPLE))]
    near = points[rows]
    near = near - near.mean(axis=1, keepdims=True)
    cov = np.einsum("nki,nkj->nij", near, near) / rows.shape[1]
    return float(np.quantile(np.linalg.eigvalsh(cov)[:, 0], 0.25))
