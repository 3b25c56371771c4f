"""Variational shape approximation of point sets (thesis 4.2-4.3): the public
`vsa_segment` and its result; the steps live in `_vsa_run`."""

from __future__ import annotations

import time
from collections.abc import Mapping
from dataclasses import dataclass, field
from types import MappingProxyType

import numpy as np

from .._core import as_int, as_normals, as_points, as_rng, readonly
from .._core._sort import spatial_renumbering
from ._graph import _check_k, neighbor_graph, permuted_neighbors
from ._kernels import (
    best_points,
    boundary_points,
    canonical_labels,
    connected_label_components,
    region_pairs,
)
from ._options import VSAOptions
from ._small import merge_small_regions
from ._sums import proxy_normals, region_sums
from ._vsa_run import _VSARun
from ._weights import resolve_weights

__all__ = ["VSAResult", "vsa_segment"]


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
        after "update", "split", "merge", "relabel", "final_merge",
        "small_regions" and "off_surface" with optimal normals.
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


def _resolve_seeds(seeds, n, indptr, indices, rng, inv):
    """Seed indices of the renumbered points (old point i is new point ``inv[i]``,
    the graph is on the new numbering) from `VSAOptions.seeds` (validated) and
    whether every point is a seed; every connected component of the graph gets
    at least one seed: its smallest-index point in the input numbering."""
    if isinstance(seeds, str):  # "all"
        return np.arange(n, dtype=np.int64), True
    if isinstance(seeds, int):
        m = as_int(seeds, "seeds", lo=1, hi=n, note="the number of points")
        chosen = as_rng(rng).choice(n, size=m, replace=False).astype(np.int64)
    else:
        chosen = seeds
        if chosen.max() >= n:
            raise ValueError(f"seeds must be point indices in [0, {n}); got {chosen.tolist()[:5]}")
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
    points, normals, *, options: VSAOptions | None = None, rng=None, neighbors=None, **settings
) -> VSAResult:
    """Segment a point set into flat regions by variational shape approximation.

    Parameters
    ----------
    points : array_like of shape (N, 3), float64
        Coordinates.
    normals : array_like of shape (N, 3), float64
        Oriented normals (rescaled to unit length).
    options : VSAOptions, optional
        The settings (default ``VSAOptions()``); see `VSAOptions` for each.
    rng : None, int or numpy.random.Generator
        Randomness for drawing an integer number of seeds.
    neighbors : ndarray of shape (N, c), int, or scipy sparse (N, N), optional
        Neighbourhood to use instead of the k-NN query (symmetrised; table entries
        < 0 mean "no neighbour").
    **settings
        Fields of `VSAOptions` given one by one (``k``, ``weights``, ``seeds``,
        ``eta``, ``max_angle``, ``split``, ``merge``, ``switch``, ``classic``,
        ``max_iter``, ``local``, ``min_region_size``); they override the same
        fields of ``options``, so ``vsa_segment(p, n, eta=25.0)`` and
        ``vsa_segment(p, n, options=VSAOptions(eta=25.0))`` are the same run.

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
        Non-integer k, seeds or max_iter; non-numeric eta or max_angle; a keyword
        that is not a field of `VSAOptions`.

    See Also
    --------
    VSAOptions : The settings, shared with `pointatlas.simplify.simplify_points`.

    Notes
    -----
    Thesis 4.2.2 (flood with a priority queue keyed |n_j - N_i|^2, proxy update
    N_i = S_i/|S_i|, re-seed), 4.3.2 (switch, Theorem 1: the energy never grows
    across a switch or an update), 4.3.3 (split by weighted PCA, merge, eta),
    Remark 6 (region adjacency). Regions are summarised by W = sum w_j and
    S = sum w_j n_j, so L21 = 2 (W - |S|) and merges cost O(1). The merged
    normal is the optimal (S_i + S_j)/|S_i + S_j| rather than the thesis'
    size-weighted one. The graph is the symmetric k-NN graph, so every point of a
    seeded component is reached. Merges may raise the energy, so they run only
    while a round of split + merge reduces the number of regions (at most
    ``VSA_MERGE_ROUNDS`` rounds); from then on split, switch and update never
    raise it and the loop ends with "converged". The batch switch skips boundary
    points whose last margin provably still holds (proxy drift bound) and is
    otherwise exact. Disconnected regions are split into their connected pieces
    at the end (end of 4.3.2); with ``merge`` and ``eta`` a last merge pass
    ("final_merge") then joins every pair of neighbouring regions whose union
    has L21 < eta, so none is left. With ``min_region_size`` (off by default)
    every region with fewer points then joins the neighbouring region, on whose
    surface it lies, whose union with it adds the least L21 ("small_regions"). With ``local`` a last
    step ("off_surface")
    moves every point that lies off its region's local surface (by more than the
    typical neighbourhood reach) to a neighbouring region on whose surface it
    lies or to a region of its own. Decisions in docs/decisions/segment.md.

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
    if options is not None and not isinstance(options, VSAOptions):
        raise TypeError(f"options must be a VSAOptions; got {type(options).__name__}")
    opts = (VSAOptions() if options is None else options).replace(**settings)
    pts = as_points(points)
    n = pts.shape[0]
    nrm = as_normals(normals, n)
    _check_k(opts.k, n, neighbors)

    t0 = time.perf_counter()
    # Every step runs on the points renumbered in a spatial (Morton) order, so
    # graph neighbours, and the regions grown from them, sit close in memory; the
    # results are mapped back and numbered in the input order at the end.
    order, inv = spatial_renumbering(pts)
    pts_r, nrm_r = np.take(pts, order, axis=0), np.take(nrm, order, axis=0)
    nb = permuted_neighbors(pts, opts.k, neighbors, order, inv)
    indptr, indices, table = neighbor_graph(pts_r, opts.k, nb)
    graph_time = time.perf_counter() - t0
    if isinstance(opts.weights, str):
        w = resolve_weights(opts.weights, n, pts_r, table, indptr, indices)
    else:
        w = resolve_weights(opts.weights, n)[order]
    seed_idx, all_seeds = _resolve_seeds(opts.seeds, n, indptr, indices, rng, inv)

    run = _VSARun(indptr, indices, pts_r, nrm_r, w, opts.eta, opts.min_cos, opts.local)
    run.timings["graph"] = graph_time
    run.start(seed_idx, all_seeds)
    if opts.classic:
        run.run_classic(opts.max_iter)
    else:
        run.run_loop(opts.max_iter, split=opts.split, merge=opts.merge, switch=opts.switch)
    t0 = time.perf_counter()
    _final_steps(run, opts)
    return _finalise(run, pts, nrm, order, inv, t0, t_start)


def _final_steps(run, opts):
    """The steps after the loop: connected pieces, the final merge (eta mode), the
    small regions (``min_region_size``), the off-surface step (local mode)."""
    run.connected_pieces()
    t1 = time.perf_counter()
    if opts.merge and not opts.classic and opts.eta is not None:
        run.final_merge()
    run.timings["final_merge"] = time.perf_counter() - t1
    if opts.min_region_size > 1:
        t1 = time.perf_counter()
        merge_small_regions(run, opts.min_region_size)
        run.timings["small_regions"] = time.perf_counter() - t1
    if opts.local and not opts.classic:
        t1 = time.perf_counter()
        run.relabel_off_surface()
        run.timings["off_surface"] = time.perf_counter() - t1


def _finalise(run, pts, nrm, order, inv, t0, t_start):
    """The `VSAResult` of a finished run in the input numbering (``pts``, ``nrm``
    the validated input), regions numbered by smallest member index; ``t0`` and
    ``t_start`` the start of the final stage and of the call."""
    labels, m = canonical_labels(run.labels[inv])
    w = run.w[inv]
    wn = w[:, None] * nrm
    wsum, ssum, counts = region_sums(labels, m, w, wn)
    prox = proxy_normals(labels, wsum, ssum, counts, nrm)
    diff = nrm - prox[labels]
    region_l21 = np.bincount(labels, weights=w * np.einsum("ij,ij->i", diff, diff), minlength=m)
    cen_w = np.where(wsum[labels] > 0, w, 1.0)
    cen_wsum = np.bincount(labels, weights=cen_w, minlength=m)
    centroids = np.empty((m, 3))
    for d in range(3):
        centroids[:, d] = np.bincount(labels, weights=cen_w * pts[:, d], minlength=m) / cen_wsum
    dist = np.einsum("ij,ij->i", pts - centroids[labels], prox[labels])
    best = best_points(labels, m, nrm, prox)
    lab_new = labels[order]  # final labels on the renumbered points, for the graph
    boundary = boundary_points(run.indptr, run.indices, lab_new)
    adjacency = region_pairs(run.indptr, run.indices, lab_new, boundary)
    timings = dict(run.timings)
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
        mse=float(np.mean(dist**2)),
        energy_history=np.asarray(run.history, dtype=np.float64),
        step_names=tuple(run.names),
        n_iter=run.n_iter,
        converged=run.converged,
        stop_reason=run.stop_reason,
        timings=timings,
    )
