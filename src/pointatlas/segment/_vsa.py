"""Variational shape approximation of point sets (thesis 4.2-4.3, GUIDE B2)."""

from __future__ import annotations

import hashlib
import math
import time
from collections.abc import Mapping
from dataclasses import dataclass, field
from types import MappingProxyType

import numpy as np

from .._core import as_float, as_int, as_normals, as_points, as_rng, readonly
from .._core._sort import spatial_renumbering
from .._core.tolerances import (
    NORMAL_ZERO_LENGTH,
    VSA_DEFAULT_MAX_ANGLE,
    VSA_MERGE_ROUNDS,
    VSA_SWITCH_FULL_SCAN,
    VSA_SWITCH_MIN_GAIN,
)
from ._graph import _check_k, neighbor_graph, permuted_neighbors
from ._kernels import (
    apply_moves,
    batch_switch_bounded,
    best_points,
    best_single_move,
    boundary_points,
    canonical_labels,
    connected_label_components,
    edge_pairs,
    flood,
    foreign_counts,
    forget_around,
    greedy_merge,
    merge_candidate_pairs,
    recount_foreign,
    region_pairs,
    renumber_memo,
    touched_points,
)

__all__ = ["VSAResult", "area_weights", "estimate_eta", "vsa_segment"]

_SWITCH_MODES = ("batch", "single", "none")


@dataclass(frozen=True, slots=True)
class VSAResult:
    """Outcome of `vsa_segment`.

    Attributes
    ----------
    labels : ndarray of shape (N,), int64
        Region of every point, 0..n_regions-1, numbered by smallest member index.
        Every region is connected in the neighbourhood graph.
    proxy_normals : ndarray of shape (n_regions, 3), float64
        Unit proxy normals N_i = S_i / |S_i| (S_i = sum of w_j n_j).
    centroids : ndarray of shape (n_regions, 3), float64
        Weighted centroids; the proxy plane passes through them (Eq. 4.7).
    seed_indices : ndarray of shape (n_regions,), int64
        The point of each region whose normal deviates least from N_i.
    seed_points : ndarray of shape (n_regions, 3), float64
        Coordinates of the seed points (the centres C_i of the thesis).
    region_l21 : ndarray of shape (n_regions,), float64
        L21 energy of every region (Eq. 4.4).
    region_counts : ndarray of shape (n_regions,), int64
        Number of points of every region.
    adjacency : ndarray of shape (E, 2), int64
        Neighbouring region pairs (Remark 6), sorted, a < b.
    energy : float
        Total L21 energy (Eq. 4.5) of the final segmentation.
    mse : float
        Mean squared point-to-proxy-plane distance (Eq. 4.7).
    energy_history : ndarray of shape (n_steps,), float64
        Energy after every step; ``step_names`` says which step. After "flood"
        and "switch" it is taken with the proxy normals that drove the step,
        after "update", "split", "merge", "relabel" and "final_merge" with
        optimal normals.
    step_names : tuple of str
        Name of every recorded step.
    n_iter : int
        Iterations of the main loop (classic: re-seed + flood + update; otherwise
        split + merge + switch + update).
    converged : bool
        True when an iteration changed nothing.
    stop_reason : str
        "converged", "cycle" (a labelling repeated; classic VSA can cycle) or
        "max_iter".
    timings : mapping of str to float
        Wall time in seconds per stage.
    """

    labels: np.ndarray
    proxy_normals: np.ndarray
    centroids: np.ndarray
    seed_indices: np.ndarray
    seed_points: np.ndarray
    region_l21: np.ndarray
    region_counts: np.ndarray
    adjacency: np.ndarray
    energy: float
    mse: float
    energy_history: np.ndarray
    step_names: tuple
    n_iter: int
    converged: bool
    stop_reason: str
    timings: Mapping = field(default_factory=dict)

    def __post_init__(self):
        for name in (
            "labels",
            "proxy_normals",
            "centroids",
            "seed_indices",
            "seed_points",
            "region_l21",
            "region_counts",
            "adjacency",
            "energy_history",
        ):
            object.__setattr__(self, name, readonly(np.array(getattr(self, name), copy=True)))
        object.__setattr__(self, "step_names", tuple(self.step_names))
        object.__setattr__(self, "timings", MappingProxyType(dict(self.timings)))

    @property
    def n_regions(self) -> int:
        """Number of regions."""
        return int(self.proxy_normals.shape[0])


# --------------------------------------------------------------------------- helpers


def _row_norms(v):
    """Euclidean norms of the rows of an (m, 3) array: ``np.linalg.norm(v, axis=1)``
    bit for bit (the same sum (x^2 + y^2) + z^2), about 6x faster at 1M rows."""
    return np.sqrt(v[:, 0] * v[:, 0] + v[:, 1] * v[:, 1] + v[:, 2] * v[:, 2])


def _sums(labels, m, w, wn):
    """Per-region W = sum w_j, S = sum w_j n_j and point counts."""
    wsum = np.bincount(labels, weights=w, minlength=m)
    ssum = np.empty((m, 3))
    for d in range(3):
        ssum[:, d] = np.bincount(labels, weights=wn[:, d], minlength=m)
    counts = np.bincount(labels, minlength=m).astype(np.int64)
    return wsum, ssum, counts


def _proxies(labels, wsum, ssum, counts, normals):
    """Optimal unit proxy normals; degenerate regions (|S| ~ 0) take a member's normal.

    With |S| = 0 every unit N gives the same energy 2 W, so the normal of the
    region's smallest-index point is as good as any and keeps results
    deterministic. Empty regions get (0, 0, 1); no point refers to them.
    """
    m = wsum.shape[0]
    length = _row_norms(ssum)
    bad = length <= NORMAL_ZERO_LENGTH * np.maximum(wsum, 1.0)
    prox = np.zeros_like(ssum)
    prox[:, 2] = 1.0
    ok = ~bad & (counts > 0)
    prox[ok] = ssum[ok] / length[ok, None]
    fix = bad & (counts > 0)
    if fix.any():
        first = np.full(m, labels.shape[0], dtype=np.int64)
        np.minimum.at(first, labels, np.arange(labels.shape[0]))
        prox[fix] = normals[first[fix]]
    return np.ascontiguousarray(prox)


def _energy_opt(wsum, ssum):
    """Total L21 at optimal normals: sum 2 (W_i - |S_i|) (GUIDE B2)."""
    return float(np.maximum(2.0 * (wsum - _row_norms(ssum)), 0.0).sum())


def _energy_fixed(wsum, ssum, prox):
    """Total L21 with given proxy normals: sum 2 (W_i - S_i . N_i)."""
    return float(np.maximum(2.0 * (wsum - np.einsum("ij,ij->i", ssum, prox)), 0.0).sum())


def _labels_key(labels):
    """Digest of a labelling up to renumbering (cycle detection).

    The canonical labels go to the hash as int32 when they fit (half the
    bytes), and SHA-256 (hardware SHA extensions) beats BLAKE2 here: 1M labels
    take about 6 ms instead of 13 ms. Only equality of digests is used.
    """
    canon, m = canonical_labels(labels)
    if m <= np.iinfo(np.int32).max:
        canon = canon.astype(np.int32)
    return hashlib.sha256(canon.tobytes()).digest()


def _over_threshold(wsum, ssum, eta, min_cos):
    length = _row_norms(ssum)
    if eta is not None:
        return 2.0 * (wsum - length) > eta
    return length < min_cos * wsum


def _split(points, w, labels, m, over):
    """Cut every region over the threshold by the plane through its weighted
    centroid orthogonal to its direction of largest weighted spread (4.3.3 a).

    ``over`` flags the regions to cut; returns the points that move, their new
    labels (new regions m, m+1, ...) and the number of cuts (regions that cannot
    be cut, e.g. all points coincide, are left alone).
    """
    idx = np.flatnonzero(over[labels])
    lab = labels[idx]
    ww = w[idx].copy()
    wr = np.bincount(lab, weights=ww, minlength=m)
    ww[wr[lab] <= 0.0] = 1.0  # all-zero weights: plain PCA
    wr = np.bincount(lab, weights=ww, minlength=m)
    counts = np.bincount(lab, minlength=m)
    p = points[idx]
    regs = np.flatnonzero(over & (wr > 0.0))  # a region without points has no centroid
    cen = np.zeros((m, 3))
    for d in range(3):
        cen[:, d] = np.bincount(lab, weights=ww * p[:, d], minlength=m)
    cen[regs] /= wr[regs, None]
    q = p - cen[lab]
    cov = np.zeros((m, 3, 3))
    for a in range(3):
        for b in range(a, 3):
            cov[:, a, b] = np.bincount(lab, weights=ww * q[:, a] * q[:, b], minlength=m)
            cov[:, b, a] = cov[:, a, b]
    _, vecs = np.linalg.eigh(cov[regs])
    direction = np.zeros((m, 3))
    direction[regs] = vecs[:, :, 2]
    side = np.einsum("ij,ij->i", q, direction[lab]) > 0.0
    n_pos = np.bincount(lab, weights=side.astype(np.float64), minlength=m)
    ok = over & (n_pos > 0) & (n_pos < counts)
    n_new = int(ok.sum())
    new_id = np.full(m, -1, dtype=np.int64)
    new_id[ok] = m + np.arange(n_new)
    move = side & ok[lab]
    return idx[move], new_id[lab[move]], n_new


def _merge(indptr, indices, labels, wsum, ssum, counts, subset, eta, min_cos, pairs=None):
    """Greedy cheapest-first merging on the region adjacency graph (4.3.3 b).

    ``subset`` holds the points whose edges give the candidate region pairs
    (None: every graph edge, i.e. every point is its own region). In eta mode
    one heap pass is exhaustive (a rejected union stays rejected as regions grow,
    since L21 only grows with the point set). In max_angle mode a rejected union
    may become acceptable after a neighbour absorbed well-aligned points, so
    passes repeat (over ``subset``, a superset of the boundary) until none merges.
    Returns labels, W, S, counts, the number of merges and the map from old to
    new region ids (None when nothing merged).
    """
    use_angle = eta is None
    total = 0
    remap_total = None
    while True:
        if pairs is not None:  # candidate pairs given (eta mode: one pass)
            pass
        elif subset is None:  # every point its own region: the pairs are the graph edges
            pairs = edge_pairs(indptr, indices)
            subset = np.arange(labels.shape[0], dtype=np.int64)
        else:
            pairs = region_pairs(indptr, indices, labels, subset)
        roots, n_merges = greedy_merge(
            pairs,
            wsum,
            ssum,
            float(eta) if eta is not None else 0.0,
            float(min_cos) if min_cos is not None else 0.0,
            use_angle,
        )
        if n_merges == 0:
            return labels, wsum, ssum, counts, total, remap_total
        total += int(n_merges)
        remap, m = canonical_labels(roots)
        remap_total = remap if remap_total is None else remap[remap_total]
        labels = remap[labels]
        wsum = np.bincount(remap, weights=wsum, minlength=m)
        ssum = np.stack([np.bincount(remap, weights=ssum[:, d], minlength=m) for d in range(3)], 1)
        counts = np.bincount(remap, weights=counts, minlength=m).astype(np.int64)
        if not use_angle:
            return labels, wsum, ssum, counts, total, remap_total
        pairs = None


def area_weights(points, *, k: int = 8, neighbors=None) -> np.ndarray:
    """Area proxy weights of Eq. 4.6: w_j = sum of |p_l - p_j|^2 over the k-NN of p_j.

    Parameters
    ----------
    points : array_like of shape (N, 3)
        Coordinates.
    k : int
        Neighbourhood size, the point itself included (it adds 0); 1 <= k <= N,
        ignored when ``neighbors`` is given.
    neighbors : ndarray of shape (N, c), int, optional
        Precomputed neighbour table (e.g. `pointatlas.neighbors.query_knn` indices).

    Returns
    -------
    weights : ndarray of shape (N,), float64
        Non-negative weights in squared input units.

    Raises
    ------
    ValueError
        Bad points, k outside [1, N], a neighbour table of the wrong shape.
    TypeError
        k not an integer.

    Notes
    -----
    Thesis Eq. 4.6; these weights approximate the area a point represents and
    matter for non-uniform samplings.

    Examples
    --------
    >>> area_weights([[0, 0, 0], [1, 0, 0], [3, 0, 0]], k=2).tolist()
    [1.0, 1.0, 4.0]
    """
    pts = as_points(points)
    k = _check_k(k, pts.shape[0], neighbors)
    if neighbors is None:
        _, _, table = neighbor_graph(pts, k)
    else:
        table = np.asarray(neighbors)
        if table.ndim != 2 or table.shape[0] != pts.shape[0]:
            raise ValueError(
                f"neighbors must be an (N, k) index table with N = {pts.shape[0]}; "
                f"got shape {table.shape}"
            )
    table = table.astype(np.int64)
    valid = table >= 0
    diff = pts[np.where(valid, table, 0)] - pts[:, None, :]
    sq = np.einsum("ijk,ijk->ij", diff, diff)
    return np.where(valid, sq, 0.0).sum(axis=1)


def estimate_eta(mean_curvature: float, n_points: int, *, curvature_split: float = 0.5) -> float:
    """Initial eta from a curvature and a target region size (thesis Eq. 4.9).

    The region is modelled as the elliptic paraboloid (u, v, u^2/a^2 + v^2/b^2) on
    [-1, 1]^2, sampled on a regular (2 nu + 1)^2 grid with nu = ceil(sqrt(n - 1) / 2),
    proxy normal (0, 0, 1).

    Parameters
    ----------
    mean_curvature : float
        H(0, 0) = 1/a^2 + 1/b^2 of Eq. 4.8, in units of 1 / (half the region width).
    n_points : int
        Number of points a region should roughly hold (>= 1).
    curvature_split : float
        Share s in [0, 1] of the curvature along u: 1/a^2 = s H, 1/b^2 = (1 - s) H.

    Returns
    -------
    eta : float
        The L21 energy (Eq. 4.9) of such a region.

    Raises
    ------
    ValueError
        Negative or non-finite curvature, n_points < 1, or curvature_split
        outside [0, 1] (or NaN).
    TypeError
        Non-integer n_points, non-numeric curvature or curvature_split.

    Notes
    -----
    Eq. 4.9: L21 = 2 (2 nu + 1)^2 - sum_{j,l=-nu..nu} 1 / sqrt((j/(nu a^2))^2 +
    (l/(nu b^2))^2 + 1/4). For n_points = 1 (nu = 0) the region is one point and
    eta = 0.

    Examples
    --------
    >>> round(estimate_eta(0.0, 100), 12)
    0.0
    >>> estimate_eta(1.0, 100) > estimate_eta(0.5, 100)
    True
    """
    h = as_float(mean_curvature, "mean_curvature", lo=0.0)
    n = as_int(n_points, "n_points", lo=1)
    s = as_float(curvature_split, "curvature_split", lo=0.0, hi=1.0)
    nu = math.ceil(math.sqrt(n - 1) / 2.0)
    if nu == 0:
        return 0.0
    inv_a2, inv_b2 = s * h, (1.0 - s) * h
    j = np.arange(-nu, nu + 1, dtype=np.float64)
    ju = (j / nu * inv_a2)[:, None]
    lv = (j / nu * inv_b2)[None, :]
    total = np.sum(1.0 / np.sqrt(ju**2 + lv**2 + 0.25))
    return float(max(2.0 * (2 * nu + 1) ** 2 - total, 0.0))


def _resolve_weights(weights, pts, k, table, indptr, indices):
    n = pts.shape[0]
    if isinstance(weights, str):
        if weights == "uniform":
            return np.ones(n)
        if weights == "area":
            if table is None:  # sparse adjacency given: use its rows
                rows = np.repeat(np.arange(n), np.diff(indptr))
                diff = pts[indices] - pts[rows]
                return np.bincount(rows, weights=np.einsum("ij,ij->i", diff, diff), minlength=n)
            return area_weights(pts, neighbors=table)
        raise ValueError(f"weights must be 'uniform', 'area' or an (N,) array; got {weights!r}")
    w = np.asarray(weights, dtype=np.float64)
    if w.shape != (n,):
        raise ValueError(f"weights must have shape ({n},); got {w.shape}")
    if not np.isfinite(w).all() or (w < 0).any():
        raise ValueError("weights must be finite and >= 0")
    return w.copy()


def _resolve_seeds(seeds, n, indptr, indices, rng, inv):
    """Seed indices of the renumbered points (old point i is new point ``inv[i]``,
    the graph is on the new numbering); every connected component of the graph
    gets at least one: its smallest-index point in the input numbering."""
    if isinstance(seeds, str):
        if seeds != "all":
            raise ValueError(f"seeds must be an int, an index array or 'all'; got {seeds!r}")
        return np.arange(n, dtype=np.int64), True
    if isinstance(seeds, int | np.integer) and not isinstance(seeds, bool):
        m = as_int(seeds, "seeds", lo=1, hi=n, note="the number of points")
        chosen = as_rng(rng).choice(n, size=m, replace=False).astype(np.int64)
    else:
        chosen = np.asarray(seeds)
        if chosen.ndim != 1 or chosen.size == 0 or not np.issubdtype(chosen.dtype, np.integer):
            raise ValueError(
                f"seeds must be an int, a non-empty 1-D integer index array or 'all'; "
                f"got {type(seeds).__name__} of shape {np.shape(seeds)}"
            )
        chosen = chosen.astype(np.int64)
        if chosen.min() < 0 or chosen.max() >= n:
            raise ValueError(f"seeds must be point indices in [0, {n}); got {chosen.tolist()[:5]}")
        if np.unique(chosen).size != chosen.size:
            raise ValueError("seeds must not repeat a point index")
    chosen = inv[chosen]
    comp, n_comp = connected_label_components(indptr, indices, np.zeros(n, dtype=np.int64))
    has = np.zeros(n_comp, dtype=bool)
    has[comp[chosen]] = True
    if not has.all():
        # the smallest-index point (input numbering) of every component without a seed
        _, first = np.unique(comp[inv], return_index=True)
        chosen = np.concatenate([chosen, inv[first[~has]]])
    return chosen, False


def vsa_segment(
    points,
    normals,
    *,
    k: int = 8,
    weights="uniform",
    seeds="all",
    eta: float | None = None,
    max_angle: float | None = None,
    split: bool = True,
    merge: bool = True,
    switch: str = "batch",
    classic: bool = False,
    max_iter: int = 1000,
    rng=None,
    neighbors=None,
) -> VSAResult:
    """Segment a point set into flat regions by variational shape approximation.

    Parameters
    ----------
    points : array_like of shape (N, 3)
        Coordinates.
    normals : array_like of shape (N, 3)
        Oriented normals (rescaled to unit length).
    k : int
        Neighbourhood size (the point itself included) of the k-NN graph used by
        flood, switch and region adjacency: 1 <= k <= N (only k >= 1 when
        ``neighbors`` is given).
    weights : {"uniform", "area"} or array_like of shape (N,)
        Point weights w_j of Eq. 4.4: 1, the area proxy of Eq. 4.6, or given.
    seeds : int, array_like of int or "all"
        Number of random seeds in [1, N] (drawn with ``rng``), seed point indices, or every
        point a seed. Every connected component of the graph without a seed gets
        its smallest-index point as an extra seed, so no point stays unassigned.
    eta : float, optional
        Split regions with L21 > eta, merge neighbours whose union has L21 < eta
        (4.3.3); finite, >= 0. Depends on the number of points per region; see
        `estimate_eta`.
    max_angle : float, optional
        Alternative threshold independent of the number of points (radians in
        [0, pi]): a
        region's mean normal deviation arccos(|S|/W) must not exceed it. With
        neither threshold, ``max_angle`` = 10 degrees is used.
    split, merge : bool
        Enable the split and merge steps.
    switch : {"batch", "single", "none"}
        "batch" moves every boundary point that lowers the energy at once (GUIDE
        B2), "single" the thesis' one best move per iteration, "none" stops after
        the initial flood (plus splits and merges).
    classic : bool
        Run the classic loop of 4.2.2 instead (flood, proxy update, re-seed,
        stopping when nothing changes or a labelling repeats); split, merge and
        switch do not apply and eta/max_angle must not be given.
    max_iter : int
        Maximum number of iterations (>= 0).
    rng : None, int or numpy.random.Generator
        Randomness for drawing an integer number of seeds.
    neighbors : ndarray of shape (N, c), int, or scipy sparse (N, N), optional
        Neighbourhood to use instead of the k-NN query (symmetrised).

    Returns
    -------
    result : VSAResult
        Labels, proxies, energies and diagnostics.

    Raises
    ------
    ValueError
        Bad shapes, non-finite values, zero normals, options out of range (the
        message names the parameter, e.g. ``k must be an integer in [1, 2000]
        (the number of points); got 100000``).
    TypeError
        Non-integer k, seeds or max_iter; non-numeric eta or max_angle.

    Notes
    -----
    Thesis 4.2.2 (flood with a priority queue keyed |n_j - N_i|^2, proxy update
    N_i = S_i/|S_i|, re-seed), 4.3.2 (switch, Theorem 1: the energy never grows
    across a switch or an update), 4.3.3 (split by weighted PCA, merge, eta),
    Remark 6 (region adjacency). Regions are summarised by W = sum w_j and
    S = sum w_j n_j, so L21 = 2 (W - |S|) and merges cost O(1) (GUIDE B2). The
    merged normal is the optimal (S_i + S_j)/|S_i + S_j| rather than the thesis'
    size-weighted one. The graph is the symmetric k-NN graph, so every point of a
    seeded component is reached. Merges may raise the energy, so they run only
    while a round of split + merge reduces the number of regions (at most
    ``VSA_MERGE_ROUNDS`` rounds); from then on split, switch and update never
    raise it and the loop ends with "converged". The batch switch skips boundary
    points whose last margin provably still holds (proxy drift bound) and is
    otherwise exact. Disconnected regions are split into their connected pieces
    at the end (end of 4.3.2); with ``merge`` and ``eta`` a last merge pass
    ("final_merge") then joins every pair of neighbouring regions whose union
    has L21 < eta, so none is left. Decisions in docs/decisions.md.

    Examples
    --------
    >>> pts = [[x, y, 0.0] for x in range(4) for y in range(3)]
    >>> pts += [[x, 3.0, z] for x in range(4) for z in range(1, 4)]
    >>> nrm = [[0, 0, 1]] * 12 + [[0, 1, 0]] * 12
    >>> res = vsa_segment(pts, nrm, k=6, eta=0.5)
    >>> res.n_regions, res.labels.tolist()[::6], float(res.energy)
    (2, [0, 0, 1, 1], 0.0)
    """
    t_start = time.perf_counter()
    timings = {}
    pts = as_points(points)
    n = pts.shape[0]
    nrm = as_normals(normals, n)
    k = _check_k(k, n, neighbors)
    max_iter = as_int(max_iter, "max_iter", lo=0)
    if switch not in _SWITCH_MODES:
        raise ValueError(f"switch must be one of {_SWITCH_MODES}; got {switch!r}")
    if eta is not None and max_angle is not None:
        raise ValueError("give eta or max_angle, not both")
    if eta is not None:
        eta = as_float(eta, "eta", lo=0.0)
    if max_angle is not None:
        max_angle = as_float(
            max_angle, "max_angle", lo=0.0, hi=math.pi, what="angle", unit="radians"
        )
    if classic and (eta is not None or max_angle is not None):
        raise ValueError("classic=True runs without split/merge; do not give eta or max_angle")
    min_cos = None
    if eta is None:
        min_cos = math.cos(VSA_DEFAULT_MAX_ANGLE if max_angle is None else max_angle)

    t0 = time.perf_counter()
    # Every step below runs on the points renumbered in a spatial (Morton) order,
    # so graph neighbours, and the regions grown from them, sit close in memory
    # (1M points in input order: 8.5 s -> 6.3 s); the results are mapped back
    # and numbered in the input order at the end.
    pts_in, nrm_in = pts, nrm
    order, inv = spatial_renumbering(pts)
    pts, nrm = np.take(pts, order, axis=0), np.take(nrm, order, axis=0)
    nb = permuted_neighbors(pts_in, k, neighbors, order, inv)
    indptr, indices, table = neighbor_graph(pts, k, nb)
    timings["graph"] = time.perf_counter() - t0
    if isinstance(weights, str):
        w = _resolve_weights(weights, pts, k, table, indptr, indices)
    else:
        w = _resolve_weights(weights, pts_in, k, None, None, None)[order]
    wn = w[:, None] * nrm
    seed_idx, all_seeds = _resolve_seeds(seeds, n, indptr, indices, rng, inv)

    names: list[str] = []
    history: list[float] = []

    def record(name, value):
        names.append(name)
        history.append(value)

    # initial flood + proxy update
    t0 = time.perf_counter()
    if all_seeds:
        labels = np.arange(n, dtype=np.int64)
        m = n
        # the sums of singletons (+ 0.0: as bincount, no -0.0)
        wsum, ssum, counts = w + 0.0, wn + 0.0, np.ones(n, dtype=np.int64)
        record("flood", 0.0)
    else:
        m = seed_idx.shape[0]
        labels = flood(indptr, indices, nrm, seed_idx, np.ascontiguousarray(nrm[seed_idx]))
        wsum, ssum, counts = _sums(labels, m, w, wn)
        record("flood", _energy_fixed(wsum, ssum, nrm[seed_idx]))
    record("update", _energy_opt(wsum, ssum))
    timings["flood"] = time.perf_counter() - t0

    converged = False
    stop_reason = "max_iter"
    n_iter = 0
    seen = {_labels_key(labels): 0}
    t_loop = {} if classic else {"split": 0.0, "merge": 0.0, "switch": 0.0, "update": 0.0}
    if classic:
        for it in range(max_iter):
            prox = _proxies(labels, wsum, ssum, counts, nrm)
            best = best_points(labels, m, nrm, prox)
            t0 = time.perf_counter()
            new = flood(indptr, indices, nrm, best, prox)
            t_loop["flood"] = t_loop.get("flood", 0.0) + time.perf_counter() - t0
            wsum, ssum, counts = _sums(new, m, w, wn)
            record("flood", _energy_fixed(wsum, ssum, prox))
            record("update", _energy_opt(wsum, ssum))
            n_iter = it + 1
            if np.array_equal(new, labels):
                converged, stop_reason = True, "converged"
                break
            key = _labels_key(new)
            labels = new
            if key in seen:
                stop_reason = "cycle"
                break
            seen[key] = n_iter
    else:
        foreign = foreign_counts(indptr, indices, labels)
        singletons = all_seeds
        # regions whose W, S changed since the merge step last looked at them
        dirty_merge = np.ones(m, dtype=np.bool_)
        # batch switch bookkeeping (see batch_switch_bounded): per point the
        # margin by which it last stayed, per region the summed proxy movement
        memo = np.full((n, 6), np.nan)
        drift = np.zeros(m)
        prev_prox = None
        merging = merge
        merge_rounds = 0
        for it in range(max_iter):
            changed = False
            n_split = n_merge = 0
            t0 = time.perf_counter()
            if split:
                over = _over_threshold(wsum, ssum, eta, min_cos)
                if over.any():
                    moved, new, n_split = _split(pts, w, labels, m, over)
                    if n_split:
                        changed = True
                        m += n_split
                        wsum = np.concatenate([wsum, np.zeros(n_split)])
                        ssum = np.concatenate([ssum, np.zeros((n_split, 3))])
                        counts = np.concatenate([counts, np.zeros(n_split, dtype=np.int64)])
                        grow = np.ones(n_split, dtype=np.bool_)
                        dirty_merge = np.concatenate([dirty_merge, grow])
                        dirty_merge[labels[moved]] = True
                        drift = np.concatenate([drift, np.zeros(n_split)])
                        forget_around(indptr, indices, moved, memo)
                        apply_moves(
                            indptr, indices, labels, wsum, ssum, counts, foreign, w, wn, moved, new
                        )
                        record("split", _energy_opt(wsum, ssum))
            t_loop["split"] += time.perf_counter() - t0
            t0 = time.perf_counter()
            if merging:
                merge_rounds += 1
                subset = pairs = None
                if singletons:
                    pass
                elif eta is not None:
                    cost = 2.0 * (wsum - _row_norms(ssum))
                    if np.count_nonzero(dirty_merge) > VSA_SWITCH_FULL_SCAN * m:
                        # most regions changed: scanning every boundary point
                        # is cheaper than filtering them
                        near = np.flatnonzero(foreign)
                    else:
                        near = touched_points(indptr, indices, labels, foreign, dirty_merge)
                    pairs = merge_candidate_pairs(
                        indptr, indices, labels, foreign, dirty_merge, cost, eta, near
                    )
                else:
                    subset = np.flatnonzero(foreign)
                labels, wsum, ssum, counts, n_merge, remap = _merge(
                    indptr, indices, labels, wsum, ssum, counts, subset, eta, min_cos, pairs
                )
                singletons = False
                if n_merge:
                    changed = True
                    m = wsum.shape[0]
                    # only boundary points next to a union change their count of
                    # foreign neighbours; they (and only they) are examined
                    # again by the switch, the others keep their memo with the
                    # regions renumbered
                    joined = np.bincount(remap, minlength=m) > 1
                    near = touched_points(indptr, indices, labels, foreign, joined)
                    recount_foreign(indptr, indices, labels, foreign, near)
                    memo[near, 0] = np.nan
                    renumber_memo(memo, remap)
                    drift = np.bincount(remap, weights=drift, minlength=m)
                    if prev_prox is not None:
                        mp = prev_prox.shape[0]
                        moved_prox = np.zeros((m, 3))
                        moved_prox[remap[:mp]] = prev_prox
                        prev_prox = moved_prox
                    record("merge", _energy_opt(wsum, ssum))
                # after a pass every neighbouring pair was (re)evaluated
                dirty_merge = np.zeros(m, dtype=np.bool_)
            t_loop["merge"] += time.perf_counter() - t0
            if switch != "none":
                t0 = time.perf_counter()
                prox = _proxies(labels, wsum, ssum, counts, nrm)
                if switch == "batch":
                    if prev_prox is not None:
                        mp = prev_prox.shape[0]
                        drift[:mp] += _row_norms(prox[:mp] - prev_prox)
                    prev_prox = prox
                    moved, new = batch_switch_bounded(
                        indptr,
                        indices,
                        nrm,
                        w,
                        labels,
                        prox,
                        foreign,
                        VSA_SWITCH_MIN_GAIN,
                        drift,
                        memo,
                    )
                else:
                    point, target, gain = best_single_move(
                        indptr, indices, nrm, w, labels, prox, foreign
                    )
                    moved = new = np.empty(0, dtype=np.int64)
                    if point >= 0 and gain > VSA_SWITCH_MIN_GAIN:
                        moved = np.array([point], dtype=np.int64)
                        new = np.array([target], dtype=np.int64)
                t_loop["switch"] += time.perf_counter() - t0
                if moved.size:
                    changed = True
                    t0 = time.perf_counter()
                    dirty_merge[labels[moved]] = True
                    dirty_merge[new] = True
                    forget_around(indptr, indices, moved, memo)
                    apply_moves(
                        indptr, indices, labels, wsum, ssum, counts, foreign, w, wn, moved, new
                    )
                    record("switch", _energy_fixed(wsum, ssum, prox))
                    record("update", _energy_opt(wsum, ssum))
                    t_loop["update"] += time.perf_counter() - t0
            n_iter = it + 1
            if not changed:
                converged, stop_reason = True, "converged"
                break
            if merging:
                # only merges can raise the energy, so only while they run can a
                # labelling repeat; afterwards the energy strictly decreases
                key = _labels_key(labels)
                if key in seen:
                    stop_reason = "cycle"
                    break
                seen[key] = n_iter
                if n_merge <= n_split or merge_rounds >= VSA_MERGE_ROUNDS:
                    # split and merge no longer shrink the region count (they only
                    # trade regions, or changed nothing): from now on only split,
                    # switch and update run, which never raise the energy
                    merging = False
    for key_name, value in t_loop.items():
        timings[key_name] = timings.get(key_name, 0.0) + value

    # final: connected pieces, proxies, measures
    t0 = time.perf_counter()
    n_before = int((counts > 0).sum())
    pieces, m_final = connected_label_components(indptr, indices, labels)
    wsum, ssum, counts = _sums(pieces, m_final, w, wn)
    if m_final != n_before:
        record("relabel", _energy_opt(wsum, ssum))
    labels, m = pieces, m_final
    t1 = time.perf_counter()
    if merge and not classic and eta is not None:
        # the switch moved points after the last merge round, and pieces cut off
        # by the relabelling are regions of their own: merge (cheapest first)
        # every neighbouring pair whose union has L21 < eta, so no such pair
        # remains; unions of adjacent connected regions stay connected. Not in
        # max_angle mode: the mean-deviation test lets a large region absorb a
        # small perpendicular one, which no later split would undo.
        subset = boundary_points(indptr, indices, labels)
        pairs = region_pairs(indptr, indices, labels, subset)
        labels, wsum, ssum, counts, n_final, _ = _merge(
            indptr, indices, labels, wsum, ssum, counts, subset, eta, min_cos, pairs
        )
        if n_final:
            labels, m = canonical_labels(labels)
            wsum, ssum, counts = _sums(labels, m, w, wn)
            record("final_merge", _energy_opt(wsum, ssum))
    timings["final_merge"] = time.perf_counter() - t1
    # back to the input numbering; regions numbered by smallest member index
    labels, m = canonical_labels(labels[inv])
    pts, nrm, w = pts_in, nrm_in, w[inv]
    wn = w[:, None] * nrm
    wsum, ssum, counts = _sums(labels, m, w, wn)
    prox = _proxies(labels, wsum, ssum, counts, nrm)
    diff = nrm - prox[labels]
    region_l21 = np.bincount(labels, weights=w * np.einsum("ij,ij->i", diff, diff), minlength=m)
    cen_w = np.where(wsum[labels] > 0, w, 1.0)
    cen_wsum = np.bincount(labels, weights=cen_w, minlength=m)
    centroids = np.empty((m, 3))
    for d in range(3):
        centroids[:, d] = np.bincount(labels, weights=cen_w * pts[:, d], minlength=m) / cen_wsum
    dist = np.einsum("ij,ij->i", pts - centroids[labels], prox[labels])
    mse = float(np.mean(dist**2))
    best = best_points(labels, m, nrm, prox)
    lab_new = labels[order]  # final labels on the renumbered points, for the graph
    adjacency = region_pairs(indptr, indices, lab_new, boundary_points(indptr, indices, lab_new))
    timings["finalize"] = time.perf_counter() - t0
    timings["total"] = time.perf_counter() - t_start
    return VSAResult(
        labels=labels,
        proxy_normals=prox,
        centroids=centroids,
        seed_indices=best,
        seed_points=pts[best],
        region_l21=region_l21,
        region_counts=counts,
        adjacency=adjacency,
        energy=float(region_l21.sum()),
        mse=mse,
        energy_history=np.asarray(history, dtype=np.float64),
        step_names=tuple(names),
        n_iter=n_iter,
        converged=converged,
        stop_reason=stop_reason,
        timings=timings,
    )
