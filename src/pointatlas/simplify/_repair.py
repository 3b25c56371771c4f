"""Absorbing regions that cannot become faces (beyond the thesis; docs/decisions/simplify.md).

The thesis removed faulty intersection points and reset face incidences by hand
(4.4.3, Fandisk). Here a region that is tiny (fewer than ``min_region_size``
points) or whose boundary does not close into cycles is merged into the adjacent
region with the most similar proxy normal, and the complex is rebuilt.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .._core import PointAtlasError
from ..complex import SurfaceComplex, surface_complex
from ._proxies import check_not_parallel, region_proxies

__all__ = [
    "CleanRegions",
    "absorb_regions",
    "clean_regions",
    "region_contacts",
    "smooth_labels",
    "split_disconnected",
]


def region_contacts(labels: np.ndarray, indices: np.ndarray, n_regions: int) -> np.ndarray:
    """Contact counts between regions from k-NN rows (dense (R, R) int64, symmetric)."""
    a = np.repeat(labels, indices.shape[1] - 1)
    b = labels[indices[:, 1:]].ravel()
    diff = a != b
    counts = np.zeros((n_regions, n_regions), dtype=np.int64)
    np.add.at(counts, (a[diff], b[diff]), 1)
    return counts + counts.T


def absorb_regions(
    labels, indices, proxy_normals, bad, by_contacts=None
) -> tuple[np.ndarray, np.ndarray]:
    """Merge every ``bad`` region into its most similar neighbour; relabel 0..R'-1.

    Returns the new labels and the map old region -> new region. Bad regions without
    a neighbour stay. Regions marked in ``by_contacts`` (pieces of a disconnected
    region) go to the neighbour sharing most k-NN contacts instead (ties: most
    similar normal, then smaller id). Chains (a bad region merged into another bad
    one) are resolved with union-find; new ids follow the smallest point index of
    each region.
    """
    n_regions = proxy_normals.shape[0]
    contacts = region_contacts(labels, indices, n_regions)
    parent = np.arange(n_regions)

    def find(x):
        while parent[x] != x:
            parent[x] = parent[parent[x]]
            x = parent[x]
        return x

    sim = proxy_normals @ proxy_normals.T
    for i in np.flatnonzero(bad):
        nbrs = np.flatnonzero(contacts[i] > 0)
        if nbrs.size == 0:
            continue
        if by_contacts is not None and by_contacts[i]:
            j = int(nbrs[np.lexsort((nbrs, -sim[i, nbrs], -contacts[i, nbrs]))[0]])
        else:
            j = int(nbrs[np.lexsort((nbrs, -contacts[i, nbrs], -sim[i, nbrs]))[0]])
        ri, rj = find(int(i)), find(j)
        if ri != rj:
            parent[ri] = rj
    root = np.array([find(i) for i in range(n_regions)])
    merged = root[labels]
    uniq, first = np.unique(merged, return_index=True)
    order = np.argsort(first, kind="stable")
    lut = np.full(n_regions, -1, dtype=np.int64)
    lut[uniq[order]] = np.arange(uniq.size)
    return lut[merged], lut[root]


def _row_majority(nb: np.ndarray) -> np.ndarray:
    """Most frequent label of every row of ``nb`` (N, k); the row's first entry (the
    point's own label) wins ties, other ties go to the label seen first in the row.

    Sorts each row (O(N k) memory, not the O(N k^2) of comparing all pairs): runs of
    equal labels give the counts, the first entry of a stable-sorted run its first
    column.
    """
    n, k = nb.shape
    order = np.argsort(nb, axis=1, kind="stable")
    srt = np.take_along_axis(nb, order, axis=1)
    start = np.ones((n, k), dtype=bool)
    start[:, 1:] = srt[:, 1:] != srt[:, :-1]
    first = np.flatnonzero(start.ravel())  # every row starts a run
    run_len = np.diff(np.append(first, n * k))
    run_row = first // k
    run_label = srt.ravel()[first]
    run_col = order.ravel()[first]
    # doubled counts, +1 for the own label: it beats an equal count, never a larger one
    score = 2 * run_len + (run_label == nb[run_row, 0])
    pick = np.lexsort((run_col, -score, run_row))
    best = pick[np.searchsorted(run_row[pick], np.arange(n))]
    return run_label[best]


def smooth_labels(labels: np.ndarray, indices: np.ndarray, n_iter: int) -> np.ndarray:
    """Majority filter over k-NN rows (own label wins ties), then connected pieces.

    Ragged VSA boundaries and one-point islands create spurious vertices in the
    complex; a few majority passes straighten them. Regions split by the filter
    become separate regions (numbered by smallest point index).
    """
    from scipy import sparse
    from scipy.sparse import csgraph

    lab = labels.copy()
    for _ in range(int(n_iter)):
        new = _row_majority(lab[indices])
        if np.array_equal(new, lab):
            break
        lab = new
    # connected pieces of every region in the symmetric k-NN graph
    n = lab.size
    rows = np.repeat(np.arange(n), indices.shape[1] - 1)
    cols = indices[:, 1:].ravel()
    same = lab[rows] == lab[cols]
    g = sparse.csr_array((np.ones(int(same.sum())), (rows[same], cols[same])), shape=(n, n))
    _, comp = csgraph.connected_components(g, directed=False)
    _, first, inv = np.unique(comp, return_index=True, return_inverse=True)
    order = np.argsort(first, kind="stable")
    rank = np.empty_like(order)
    rank[order] = np.arange(order.size)
    return rank[inv.reshape(-1)].astype(np.int64)


def split_disconnected(labels: np.ndarray, indices: np.ndarray) -> np.ndarray:
    """Connected pieces of every region in the symmetric k-NN graph of ``indices``.

    The largest piece of a region keeps its id (ties: the piece with the smallest
    point); the other pieces get new ids R, R+1, ... in order of their smallest
    point, so connected labellings come back unchanged (private).
    """
    from scipy import sparse
    from scipy.sparse import csgraph

    n = labels.size
    rows = np.repeat(np.arange(n), indices.shape[1] - 1)
    cols = indices[:, 1:].ravel()
    same = labels[rows] == labels[cols]
    g = sparse.csr_array((np.ones(int(same.sum())), (rows[same], cols[same])), shape=(n, n))
    _, comp = csgraph.connected_components(g, directed=False)
    uniq, first, inv = np.unique(comp, return_index=True, return_inverse=True)
    inv = inv.reshape(-1)
    size = np.bincount(inv)
    reg = labels[first]
    # per region: the largest piece (then smallest first point) keeps the region id
    order = np.lexsort((first, -size, reg))
    keeps = np.zeros(uniq.size, dtype=bool)
    head = np.ones(order.size, dtype=bool)
    head[1:] = reg[order][1:] != reg[order][:-1]
    keeps[order[head]] = True
    new_id = np.where(keeps, reg, -1)
    extra = np.flatnonzero(~keeps)
    extra = extra[np.argsort(first[extra], kind="stable")]
    new_id[extra] = int(labels.max()) + 1 + np.arange(extra.size)
    return new_id[inv].astype(np.int64)


def _proxies_for(points, normals, labels, region_map, pn0, ctr0, base_valid):
    """Proxy normals/centers for the current labels: the given ones for regions that
    are one unchanged input region, recomputed from the points otherwise."""
    prox = region_proxies(points, normals, labels)
    n_cur = prox.normals.shape[0]
    counts = np.bincount(region_map, minlength=n_cur)
    pn = np.array(prox.normals)
    ctr = np.array(prox.centroids)
    single = np.flatnonzero((counts[region_map] == 1) & base_valid)
    pn[region_map[single]] = pn0[single]
    ctr[region_map[single]] = ctr0[single]
    return pn, ctr, prox


@dataclass(frozen=True, slots=True)
class CleanRegions:
    """Result of `clean_regions` (private): the labels meshed, their proxies and
    complex, which input region went where, and the points the plane fit may use."""

    labels: np.ndarray
    input_map: np.ndarray
    proxy_normals: np.ndarray
    centers: np.ndarray
    centroids: np.ndarray
    surface_complex: SurfaceComplex
    fit_mask: np.ndarray
    input_reasons: tuple = ()


def clean_regions(
    points,
    normals,
    labels,
    indices,
    pn0,
    ctr0,
    *,
    k,
    smooth,
    min_region_size,
    repair,
    max_boundary_fraction,
) -> CleanRegions:
    """Smooth the labels, merge tiny/strip regions, then (``repair``) regions whose
    boundary does not close into simple cycles, and build the complex (private;
    validated input, working coordinates; see `simplify_segmentation`)."""
    n_regions = int(labels.max()) + 1
    cur, is_piece, base_valid, pn0, ctr0, fit_mask = _base_pieces(
        labels, indices, smooth, pn0, ctr0
    )
    region_map = np.arange(int(cur.max()) + 1)  # base piece -> current region
    reasons = [""] * n_regions
    strips = repair and max_boundary_fraction < 1.0
    bad, why = _small_regions(
        cur, indices, is_piece, min_region_size, max_boundary_fraction if strips else None
    )
    by_contacts = is_piece.copy()
    for _round in range(31):
        stop = False
        if bad.any():
            cur_pn = _proxies_for(points, normals, cur, region_map, pn0, ctr0, base_valid)[0]
            new_labels, step = absorb_regions(cur, indices, cur_pn, bad, by_contacts)
            if int(new_labels.max()) + 1 >= 3:
                _record(reasons, labels, cur, bad, why)
                cur, region_map = new_labels, step[region_map]
            else:  # merging would leave no polyhedron: keep the regions as they are
                stop = True
        pn, ctr, cprox = _proxies_for(points, normals, cur, region_map, pn0, ctr0, base_valid)
        n_cur = pn.shape[0]
        if n_cur < 3:
            raise PointAtlasError(
                f"simplification needs at least 3 regions (three planes meeting at a "
                f"vertex); got {n_cur} after merging regions too small to mesh"
            )
        check_not_parallel(pn)
        cplx = surface_complex(points, cur, k=k, neighbors=indices)
        if not any(len(r) >= 3 for r in cplx.vertex_regions):
            raise PointAtlasError(
                f"no vertex where three or more regions meet (k = {k}); the {n_cur} "
                "regions do not form a closed polygon mesh"
            )
        if not repair or stop:
            break
        bad_now, why = _unmeshable_regions(cplx)
        if not bad_now.any():
            break
        by_contacts = None
        # merge the smallest quarter of the failing regions per round
        sizes = np.bincount(cur, minlength=n_cur)
        cand = np.flatnonzero(bad_now)
        cand = cand[np.lexsort((cand, sizes[cand]))][: max(1, cand.size // 4)]
        bad = np.zeros(n_cur, dtype=bool)
        bad[cand] = True
    both = np.zeros((n_regions, pn.shape[0]), dtype=np.int64)
    np.add.at(both, (labels, cur), 1)
    return CleanRegions(
        labels=cur,
        input_map=both.argmax(axis=1),  # input region -> final region holding most of it
        proxy_normals=pn,
        centers=ctr,
        centroids=np.asarray(cprox.centroids),
        surface_complex=cplx,
        fit_mask=fit_mask,
        input_reasons=tuple(reasons),
    )


def _base_pieces(labels, indices, smooth, pn0, ctr0):
    """The labels smoothed (or split into k-NN-connected pieces) and what the pieces
    keep of their input region: (labels, is_piece, base_valid, pn0, ctr0, fit_mask).

    Every region ends up connected in the k-NN graph (issue 14 item 6): the majority
    filter splits into pieces itself; without it, disconnected regions are split
    here. A piece keeps its input region's proxy unless the region was split
    (``base_valid``); points the majority filter relabelled to another input region
    stay out of the plane fit of ``vertices="fit"`` (``fit_mask``).
    """
    n_regions = int(labels.max()) + 1
    base_valid = np.ones(n_regions, dtype=bool)
    fit_mask = np.ones(labels.shape[0], dtype=bool)
    cur = smooth_labels(labels, indices, smooth) if smooth else split_disconnected(labels, indices)
    is_piece = np.zeros(int(cur.max()) + 1, dtype=bool)
    if not smooth:
        is_piece[n_regions:] = True
    if int(cur.max()) + 1 != n_regions or not np.array_equal(cur, labels):
        pair_counts = np.zeros((int(cur.max()) + 1, n_regions), dtype=np.int64)
        np.add.at(pair_counts, (cur, labels), 1)
        owner = pair_counts.argmax(axis=1)
        base_valid = np.bincount(owner, minlength=n_regions)[owner] == 1
        pn0, ctr0 = pn0[owner], ctr0[owner]
        fit_mask = owner[cur] == labels
        if smooth:  # pieces: all but the largest base piece of an input region
            nb = owner.size
            sizes_b = np.bincount(cur, minlength=nb)
            order = np.lexsort((np.arange(nb), -sizes_b, owner))
            head = np.ones(nb, dtype=bool)
            head[1:] = owner[order][1:] != owner[order][:-1]
            is_piece[order[~head]] = True
    return cur, is_piece, base_valid, pn0, ctr0, fit_mask


def _small_regions(cur, indices, is_piece, min_region_size, max_boundary_fraction):
    """Regions merged before the first complex, and why: fewer than
    ``min_region_size`` points, and (``max_boundary_fraction`` given) thin strips."""
    n_cur0 = int(cur.max()) + 1
    sizes0 = np.bincount(cur, minlength=n_cur0)
    bad = sizes0 < int(min_region_size)
    why = [f"fewer than min_region_size = {int(min_region_size)} points ({int(c)})" for c in sizes0]
    for c in np.flatnonzero(is_piece & bad):
        why[c] = (
            f"a disconnected piece of {int(sizes0[c])} points (fewer than {int(min_region_size)})"
        )
    if max_boundary_fraction is not None:
        # thin regions: (almost) every point sees another region; their two sides
        # see each other across them and the complex cannot separate them
        on_boundary = (cur[indices] != cur[:, None]).any(axis=1)
        frac = np.bincount(cur, weights=on_boundary, minlength=n_cur0) / np.maximum(
            np.bincount(cur, minlength=n_cur0), 1
        )
        # only regions smaller than half the largest count as strips (on a coarse
        # sampling every region may have all its points near a boundary)
        strip = (frac > max_boundary_fraction) & (sizes0 < 0.5 * sizes0.max()) & ~bad
        for c in np.flatnonzero(strip):
            why[c] = (
                f"a thin strip ({100 * frac[c]:.0f} % of its points see another region "
                f"among their k = {indices.shape[1]} neighbours)"
            )
        bad |= strip
    return bad, why


def _unmeshable_regions(cplx):
    """Regions of the complex without a closed boundary cycle, with an open boundary
    or a boundary cycle that is not simple, and why: (bad (R,) bool, reasons)."""
    no_cycle = np.array([len(rc) == 0 for rc in cplx.region_cycles])
    bad_now = no_cycle.copy()
    why = ["no closed boundary cycle in the complex" if x else "" for x in no_cycle]
    for c in cplx.regions_open:
        bad_now[c] = True
        why[c] = why[c] or "its boundary does not close into cycles"
    for c in cplx.cycles_not_simple:
        bad_now[cplx.cycle_region[c]] = True
        why[cplx.cycle_region[c]] = why[cplx.cycle_region[c]] or "a boundary cycle is not simple"
    return bad_now, why


def _record(reasons, labels, cur, bad, why):
    """Note why an input region is merged away: the first time the current region
    holding most of its points is absorbed (private)."""
    n_in, n_cur = len(reasons), int(cur.max()) + 1
    both = np.zeros((n_in, n_cur), dtype=np.int64)
    np.add.at(both, (labels, cur), 1)
    main = both.argmax(axis=1)
    for r in range(n_in):
        if not reasons[r] and both[r].any() and bad[main[r]]:
            reasons[r] = "merged into a neighbour: " + why[main[r]]
