"""Smooth region growing of Rabbani et al. (2006), as PCL's ``RegionGrowing``."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .._core import as_float, as_int, as_normals, as_points, check_neighbors, readonly
from .._core.tolerances import NORMAL_ZERO_LENGTH
from ._graph import _check_k, neighbor_graph
from ._kernels import region_growing as _grow_kernel

__all__ = ["RegionGrowingResult", "region_growing", "surface_curvature"]


@dataclass(frozen=True, slots=True)
class RegionGrowingResult:
    """Outcome of `region_growing`.

    Attributes
    ----------
    labels : ndarray of shape (N,), int64
        Region of every point, 0..n_regions-1 in growth order; -1 for points in
        clusters outside [min_cluster_size, max_cluster_size] (PCL drops those).
    proxy_normals : ndarray of shape (n_regions, 3), float64
        Mean normal S/|S| of every region; NaN rows where |S| = 0 (PCL's "zero
        proxy normal" failure the thesis reports for antipodal normals).
    centroids : ndarray of shape (n_regions, 3), float64
        Centroid of every region.
    region_counts : ndarray of shape (n_regions,), int64
        Points per region.
    region_l21 : ndarray of shape (n_regions,), float64
        L21 energy of every region with its mean normal (NaN where degenerate).
    curvature : ndarray of shape (N,), float64
        Surface variation used for seed order and the seed test.
    assigned_fraction : float
        Share of points with a label >= 0.
    mse : float
        Eq. 4.7 over the assigned points (NaN when none is assigned or a region
        is degenerate).
    """

    labels: np.ndarray
    proxy_normals: np.ndarray
    centroids: np.ndarray
    region_counts: np.ndarray
    region_l21: np.ndarray
    curvature: np.ndarray
    assigned_fraction: float
    mse: float

    def __post_init__(self):
        for name in (
            "labels",
            "proxy_normals",
            "centroids",
            "region_counts",
            "region_l21",
            "curvature",
        ):
            object.__setattr__(self, name, readonly(np.array(getattr(self, name), copy=True)))

    @property
    def n_regions(self) -> int:
        """Number of regions kept."""
        return int(self.region_counts.shape[0])

    @property
    def n_degenerate(self) -> int:
        """Regions whose mean normal is zero (no proxy plane)."""
        return int(np.isnan(self.proxy_normals[:, 0]).sum())


def surface_curvature(points, *, k: int = 8, neighbors=None) -> np.ndarray:
    """Surface variation l3 / (l1 + l2 + l3) of every point's k-NN covariance.

    Parameters
    ----------
    points : array_like of shape (N, 3)
        Coordinates.
    k : int
        Neighbourhood size, the point itself included (1 <= k <= N; ignored when
        ``neighbors`` is given).
    neighbors : ndarray of shape (N, c), int, optional
        Precomputed neighbour table (column 0 the point itself; indices in [0, N)).

    Returns
    -------
    curvature : ndarray of shape (N,), float64
        In [0, 1/3]; 0 where all neighbours coincide. l3 is the smallest eigenvalue.

    Raises
    ------
    ValueError
        Bad points, k outside [1, N], or a neighbour table of the wrong shape or
        with indices outside [0, N).
    TypeError
        k not an integer, or a non-integer neighbour table.

    Notes
    -----
    PCL's ``NormalEstimation`` curvature, used by its ``RegionGrowing``.

    Examples
    --------
    >>> pts = [[x, y, 0.0] for x in range(3) for y in range(3)]
    >>> float(surface_curvature(pts, k=5).max())
    0.0
    """
    pts = as_points(points)
    k = _check_k(k, pts.shape[0], neighbors)
    if neighbors is None:
        _, _, table = neighbor_graph(pts, k)
    else:
        table = check_neighbors(neighbors, pts.shape[0])
    out = np.empty(pts.shape[0])
    chunk = 200_000
    for s in range(0, pts.shape[0], chunk):
        nb = pts[table[s : s + chunk]]
        q = nb - nb.mean(axis=1, keepdims=True)
        cov = np.einsum("nki,nkj->nij", q, q)
        ev = np.linalg.eigvalsh(cov)
        total = ev.sum(axis=1)
        out[s : s + chunk] = np.where(
            total > 0, np.clip(ev[:, 0], 0.0, None) / np.where(total > 0, total, 1.0), 0.0
        )
    return out


def region_growing(
    points,
    normals,
    *,
    k: int = 8,
    smoothness_angle: float = math.radians(15.0),
    curvature_threshold: float | None = None,
    min_cluster_size: int = 1,
    max_cluster_size: int | None = None,
    curvature=None,
    neighbors=None,
) -> RegionGrowingResult:
    """Segment by smooth region growing (Rabbani et al. 2006; PCL ``RegionGrowing``).

    Parameters
    ----------
    points : array_like of shape (N, 3)
        Coordinates.
    normals : array_like of shape (N, 3)
        Normals (orientation is ignored, as in PCL: |n_i . n_j| is compared).
    k : int
        Neighbours per point, the point itself included (PCL
        ``setNumberOfNeighbours``); 1 <= k <= N, only k >= 1 when ``neighbors``
        is given.
    smoothness_angle : float
        A neighbour joins when the angle between its normal and the current
        point's is at most this (radians in [0, pi]; PCL ``setSmoothnessThreshold``).
    curvature_threshold : float, optional
        Joined points with curvature <= this (finite) continue the growth (PCL
        ``setCurvatureThreshold``). Default: the 98th percentile of the curvatures,
        Rabbani et al.'s percentile rule for the residual threshold.
    min_cluster_size, max_cluster_size : int
        Regions outside this size range are dropped (label -1), as PCL does;
        1 <= min_cluster_size <= max_cluster_size. A min_cluster_size above N is
        valid and leaves every point unassigned (no regions, ``mse`` NaN).
    curvature : array_like of shape (N,), optional
        Precomputed curvature (default `surface_curvature` with the same k).
    neighbors : ndarray of shape (N, c), int, optional
        Precomputed k-NN table (column 0 the point itself), e.g. from PCL;
        entries < 0 mean "no neighbour" (then give ``curvature`` too:
        `surface_curvature` needs a full table).

    Returns
    -------
    result : RegionGrowingResult
        Labels (-1 = unassigned), region normals, measures.

    Raises
    ------
    ValueError
        Bad shapes, non-finite values, or parameters out of range (the message
        names the parameter).
    TypeError
        Non-integer k or cluster sizes, non-numeric thresholds.

    Notes
    -----
    Seeds are visited by increasing curvature (ties: smaller index), a region
    grows breadth-first over the directed k-NN lists; everything as in PCL 1.x
    ``RegionGrowing::applySmoothRegionGrowingAlgorithm`` with the smoothness
    mode on. Baseline of Table 4.1 (thesis 4.3.4, [RVDHV06]).

    Examples
    --------
    >>> pts = [[x, y, 0.0] for x in range(4) for y in range(4)]
    >>> pts += [[x, 4.0, z] for x in range(4) for z in range(1, 4)]
    >>> nrm = [[0, 0, 1]] * 16 + [[0, 1, 0]] * 12
    >>> res = region_growing(pts, nrm, k=5, curvature_threshold=1.0)
    >>> res.n_regions, res.assigned_fraction
    (2, 1.0)
    """
    pts = as_points(points)
    n = pts.shape[0]
    nrm = as_normals(normals, n)
    k = _check_k(k, n, neighbors)
    min_cluster_size = as_int(min_cluster_size, "min_cluster_size", lo=1)
    if max_cluster_size is not None:
        max_cluster_size = as_int(
            max_cluster_size, "max_cluster_size", lo=min_cluster_size, note=">= min_cluster_size"
        )
    angle = as_float(
        smoothness_angle, "smoothness_angle", lo=0.0, hi=math.pi, what="angle", unit="radians"
    )
    if curvature_threshold is None:
        thr = None
    else:
        thr = as_float(curvature_threshold, "curvature_threshold")
    if neighbors is None:
        _, _, table = neighbor_graph(pts, k)
    else:
        table = check_neighbors(neighbors, n, allow_negative=True)
    if curvature is None:
        curv = surface_curvature(pts, neighbors=table)
    else:
        curv = np.asarray(curvature, dtype=np.float64)
        if curv.shape != (n,) or not np.isfinite(curv).all():
            raise ValueError(f"curvature must be a finite ({n},) array; got shape {curv.shape}")
    if thr is None:
        thr = float(np.percentile(curv, 98.0))
    order = np.lexsort((np.arange(n), curv))
    raw = _grow_kernel(np.ascontiguousarray(table), nrm, curv, order, math.cos(angle), thr)
    labels, m = _drop_clusters(raw, min_cluster_size, max_cluster_size)
    return _measures(pts, nrm, labels, m, curv)


def _drop_clusters(raw, min_size, max_size):
    """Labels 0..m-1 (growth order) of the regions of ``raw`` with min_size <=
    size <= max_size (None: no upper bound), -1 for the others; and m."""
    sizes = np.bincount(raw)
    keep = sizes >= min_size
    if max_size is not None:
        keep &= sizes <= max_size
    new_id = np.full(sizes.shape[0], -1, dtype=np.int64)
    new_id[keep] = np.arange(int(keep.sum()))
    return new_id[raw], int(keep.sum())


def _measures(pts, nrm, labels, m, curv):
    """`RegionGrowingResult` of the labels: mean normals (NaN where |S| = 0),
    centroids, L21 and Eq. 4.7 over the assigned points."""
    n = pts.shape[0]
    sel = labels >= 0
    lab = labels[sel]
    counts = np.bincount(lab, minlength=m).astype(np.int64)
    # float64 also when no point is kept (bincount of nothing is int64)
    ssum = np.stack([np.bincount(lab, weights=nrm[sel, d], minlength=m) for d in range(3)], 1)
    ssum = ssum.astype(np.float64, copy=False)
    length = np.linalg.norm(ssum, axis=1)
    degenerate = length <= NORMAL_ZERO_LENGTH * np.maximum(counts, 1)
    prox = np.full((m, 3), np.nan)
    prox[~degenerate] = ssum[~degenerate] / length[~degenerate, None]
    cen = np.stack([np.bincount(lab, weights=pts[sel, d], minlength=m) for d in range(3)], 1)
    cen = cen.astype(np.float64, copy=False) / np.maximum(counts, 1)[:, None]
    l21 = np.where(degenerate, np.nan, 2.0 * (counts - length))
    l21 = np.where(np.isnan(l21), np.nan, np.maximum(l21, 0.0))
    if lab.size and not degenerate.any():
        dist = np.einsum("ij,ij->i", pts[sel] - cen[lab], prox[lab])
        mse = float(np.mean(dist**2))
    else:
        mse = float("nan")
    return RegionGrowingResult(
        labels=labels,
        proxy_normals=prox,
        centroids=cen,
        region_counts=counts,
        region_l21=l21,
        curvature=curv,
        assigned_fraction=float(sel.mean()) if n else 0.0,
        mse=mse,
    )
