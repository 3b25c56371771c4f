"""Linear proxies (N_i, centroid, C_i) of labelled regions (thesis 4.2-4.3, Eqs. 4.4-4.7)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .._core import PointAtlasError, as_labels, as_normals, as_points, readonly
from .._core.tolerances import NORMAL_ZERO_LENGTH, SIMPLIFY_PARALLEL_ANGLE

__all__ = ["RegionProxies", "check_not_parallel", "region_proxies"]


@dataclass(frozen=True, slots=True)
class RegionProxies:
    """Linear proxies of the regions of a segmentation.

    Attributes
    ----------
    normals : ndarray of shape (R, 3), float64
        Proxy normals N_i: the normalised (weighted) sum of the region's normals,
        the minimiser of the L^{2,1} energy (Eq. 4.5).
    centroids : ndarray of shape (R, 3), float64
        (Weighted) centroids; the proxy plane of Eq. 4.7 passes through them.
    seed_points : ndarray of shape (R, 3), float64
        C_i: the region point whose normal deviates least from N_i (ties: smaller
        index), as VSA re-seeds (4.2.2).
    sizes : ndarray of shape (R,), int64
        Number of points per region.
    energy : ndarray of shape (R,), float64
        L^{2,1}(P_i, N_i) of Eq. 4.4 at the optimal N_i = S_i / |S_i|: for unit normals
        2 (W_i - |S_i|) with W_i = sum w_j and S_i = sum w_j n_j.
    """

    normals: np.ndarray
    centroids: np.ndarray
    seed_points: np.ndarray
    sizes: np.ndarray
    energy: np.ndarray

    def __post_init__(self):
        for name in ("normals", "centroids", "seed_points", "sizes", "energy"):
            readonly(getattr(self, name))


def region_proxies(points, normals, labels, *, weights=None) -> RegionProxies:
    """Proxy normal, centroid and seed point of every region.

    Parameters
    ----------
    points : array_like of shape (N, 3), float64
        Coordinates.
    normals : array_like of shape (N, 3), float64
        Normals (rescaled to unit length).
    labels : array_like of shape (N,), int64
        Region of every point, consecutive 0..R-1.
    weights : array_like of shape (N,), float64, optional
        Non-negative point weights w_j (Eq. 4.4); 1 when omitted.

    Returns
    -------
    proxies : RegionProxies
        Normals, centroids, seed points, sizes and L^{2,1} energies.

    Raises
    ------
    ValueError
        Bad shapes, negative or non-consecutive labels, bad weights.
    PointAtlasError
        A region whose normals cancel out (no proxy normal).

    Notes
    -----
    Thesis 4.2.2/4.3: N_i = S_i / |S_i| with S_i = sum w_j n_j; the seed point C_i
    is the point of least normal deviation |n_j - N_i|^2.

    Examples
    --------
    >>> import numpy as np
    >>> pts = np.array([[0, 0, 0], [1, 0, 0], [0, 0, 1.0]])
    >>> nrm = np.array([[0, 0, 1], [0, 0, 1], [1, 0, 0.0]])
    >>> region_proxies(pts, nrm, [0, 0, 1]).centroids.tolist()
    [[0.5, 0.0, 0.0], [0.0, 0.0, 1.0]]
    """
    pts = as_points(points)
    n = pts.shape[0]
    nrm = as_normals(normals, n)
    lab = as_labels(labels, n)
    if (lab < 0).any():
        raise ValueError(f"labels must be >= 0; {int((lab < 0).sum())} points are unassigned")
    if weights is None:
        w = np.ones(n)
    else:
        w = np.asarray(weights, dtype=np.float64)
        if w.shape != (n,):
            raise ValueError(f"weights must have shape ({n},); got {w.shape}")
        if not np.isfinite(w).all() or (w < 0).any():
            raise ValueError("weights must be finite and non-negative")
    r = int(lab.max()) + 1
    sizes = np.bincount(lab, minlength=r).astype(np.int64)
    if (sizes == 0).any():
        missing = np.flatnonzero(sizes == 0)[:5].tolist()
        raise ValueError(f"labels must be consecutive 0..{r - 1}; missing {missing}")
    wsum = np.bincount(lab, weights=w, minlength=r)
    s = np.stack([np.bincount(lab, weights=w * nrm[:, d], minlength=r) for d in range(3)], 1)
    c = np.stack([np.bincount(lab, weights=w * pts[:, d], minlength=r) for d in range(3)], 1)
    norm_s = np.linalg.norm(s, axis=1)
    bad = norm_s <= NORMAL_ZERO_LENGTH * np.maximum(wsum, 1.0)
    if bad.any():
        raise PointAtlasError(
            f"regions {np.flatnonzero(bad)[:5].tolist()} have normals that cancel out; "
            "no proxy normal is defined"
        )
    normals_out = s / norm_s[:, None]
    zero_w = wsum <= 0
    centroids = np.where(
        zero_w[:, None],
        np.stack([np.bincount(lab, weights=pts[:, d], minlength=r) for d in range(3)], 1)
        / sizes[:, None],
        c / np.where(zero_w, 1.0, wsum)[:, None],
    )
    dev = np.einsum("ij,ij->i", nrm - normals_out[lab], nrm - normals_out[lab])
    order = np.lexsort((np.arange(n), dev, lab))
    first = order[np.searchsorted(lab[order], np.arange(r))]
    energy = 2.0 * (wsum - norm_s)
    return RegionProxies(
        normals=normals_out,
        centroids=centroids,
        seed_points=pts[first].copy(),
        sizes=sizes,
        energy=np.maximum(energy, 0.0),
    )


def check_not_parallel(normals: np.ndarray) -> None:
    """Raise when all proxy normals (R, 3), unit, lie within
    ``SIMPLIFY_PARALLEL_ANGLE`` of one direction (up to sign): no vertex is defined."""
    cosines = np.abs(normals @ normals[0])
    if cosines.min() >= np.cos(SIMPLIFY_PARALLEL_ANGLE):
        raise PointAtlasError(
            f"all {normals.shape[0]} proxy planes are parallel (within "
            f"{np.degrees(SIMPLIFY_PARALLEL_ANGLE):.0f} degrees); no mesh vertex can be placed"
        )
