"""Absorbing regions that cannot become faces (beyond the thesis; docs/decisions.md).

The thesis removed faulty intersection points and reset face incidences by hand
(4.4.3, Fandisk). Here a region that is tiny (fewer than ``min_region_size``
points) or whose boundary does not close into cycles is merged into the adjacent
region with the most similar proxy normal, and the complex is rebuilt.
"""

from __future__ import annotations

import numpy as np

__all__ = ["absorb_regions", "region_contacts"]


def region_contacts(labels: np.ndarray, indices: np.ndarray, n_regions: int) -> np.ndarray:
    """Contact counts between regions from k-NN rows (dense (R, R) int64, symmetric)."""
    a = np.repeat(labels, indices.shape[1] - 1)
    b = labels[indices[:, 1:]].ravel()
    diff = a != b
    counts = np.zeros((n_regions, n_regions), dtype=np.int64)
    np.add.at(counts, (a[diff], b[diff]), 1)
    return counts + counts.T


def absorb_regions(labels, indices, proxy_normals, bad) -> tuple[np.ndarray, np.ndarray]:
    """Merge every ``bad`` region into its most similar neighbour; relabel 0..R'-1.

    Returns the new labels and the map old region -> new region. Bad regions without
    a neighbour stay. Chains (a bad region merged into another bad one) are resolved
    with union-find; new ids follow the smallest point index of each region.
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
        nb = lab[indices]
        counts = (nb[:, :, None] == nb[:, None, :]).sum(axis=1).astype(np.float64)
        counts[:, 0] += 0.5  # ties keep the point's own label (column 0 is the point)
        new = nb[np.arange(nb.shape[0]), counts.argmax(axis=1)]
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
