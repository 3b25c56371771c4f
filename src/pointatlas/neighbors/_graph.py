"""The k-NN graph, its connected components and the mean spacing l."""

from __future__ import annotations

import numpy as np
from scipy import sparse
from scipy.sparse import csgraph

from .._core import as_int, as_points, check_neighbors
from . import _kernels
from ._knn import query_knn

__all__ = ["knn_graph", "knn_components", "mean_spacing"]


def knn_graph(points, k: int, *, symmetric: bool = True, neighbors=None) -> sparse.csr_array:
    """The k-NN graph as a sparse matrix of distances.

    Parameters
    ----------
    points : array_like of shape (N, 3)
        Coordinates.
    k : int
        Neighbourhood size including the point itself (self loops are not
        stored); 1 <= k <= N, only k >= 1 when ``neighbors`` is given.
    symmetric : bool
        If True (default) i ~ j when either is among the other's k nearest.
    neighbors : ndarray of shape (N, m), int, or tuple, optional
        Precomputed `query_knn` indices (or the tuple it returns; avoids a second
        query); column 0 (the point itself) is ignored, all m columns are used.

    Returns
    -------
    graph : scipy.sparse.csr_array of shape (N, N), float64
        Entry (i, j) is the distance |p_i - p_j|. Exact duplicates are stored as
        explicit zeros, so use ``graph.indices``/``indptr`` (the structure), not
        ``graph.data != 0``, for adjacency. Columns are sorted within each row.

    Raises
    ------
    ValueError
        Bad points; k outside [1, N]; ``neighbors`` of the wrong shape or range.
    TypeError
        k not an integer; ``neighbors`` not integer.

    Notes
    -----
    The structure is built by a numba kernel (counting scatter, per-row sort and
    de-duplication); distances are evaluated on bounding-box-centred
    coordinates, as in `query_knn`.

    Examples
    --------
    >>> g = knn_graph([[0, 0, 0], [1, 0, 0], [5, 0, 0]], 2)
    >>> g.toarray().tolist()
    [[0.0, 1.0, 0.0], [1.0, 0.0, 4.0], [0.0, 4.0, 0.0]]
    """
    pts = as_points(points)
    n = pts.shape[0]
    if neighbors is None:
        table, _ = query_knn(pts, k)
    else:
        as_int(k, "k", lo=1)
        table = check_neighbors(neighbors, n)
    nbr = np.ascontiguousarray(table[:, 1:])
    indptr, cols = _kernels.graph_structure(nbr, n, bool(symmetric))
    # distances on bounding-box-centred coordinates, like query_knn
    centred = pts - 0.5 * np.add(*_kernels.bounds(pts)) if n else pts
    dist = _kernels.edge_lengths(centred, indptr, cols)
    return sparse.csr_array((dist, cols, indptr), shape=(n, n))


def knn_components(points, k: int, *, neighbors=None) -> tuple[int, np.ndarray]:
    """Connected components of the symmetric k-NN graph.

    Parameters
    ----------
    points : array_like of shape (N, 3)
        Coordinates.
    k : int
        Neighbourhood size including the point itself (1 <= k <= N, only
        k >= 1 when ``neighbors`` is given).
    neighbors : ndarray of shape (N, m), int, or tuple, optional
        Precomputed `query_knn` indices (or the tuple it returns).

    Returns
    -------
    n_components : int
        Number of components.
    labels : ndarray of shape (N,), int64
        Component of every point, numbered by smallest member index.

    Raises
    ------
    ValueError
        As `knn_graph`.
    TypeError
        k not an integer.

    Examples
    --------
    >>> knn_components([[0, 0, 0], [1, 0, 0], [9, 0, 0], [10, 0, 0]], 2)[0]
    2
    """
    graph = knn_graph(points, k, neighbors=neighbors)
    structure = sparse.csr_array(
        (np.ones_like(graph.data), graph.indices, graph.indptr), shape=graph.shape
    )
    n_comp, labels = csgraph.connected_components(structure, directed=False)
    # renumber by first occurrence so the numbering is canonical
    _, first = np.unique(labels, return_index=True)
    rank = np.empty(n_comp, dtype=np.int64)
    rank[np.argsort(first, kind="stable")] = np.arange(n_comp)
    return int(n_comp), rank[labels]


def mean_spacing(points, k: int = 12, *, distances=None) -> float:
    """Mean distance l of all points to their k nearest neighbours.

    Parameters
    ----------
    points : array_like of shape (N, 3)
        Coordinates (N >= k + 1).
    k : int
        Number of neighbours, the point itself excluded (12 by default; 6 in 5.4's
        denoising application): 1 <= k <= N - 1, or at most the columns of
        ``distances`` minus 1.
    distances : ndarray of shape (N, >= k + 1), float64, optional
        Precomputed `query_knn` distances (column 0 is the point itself).

    Returns
    -------
    l : float
        The length unit of "noise of amplitude x %" (the mean spacing l).

    Raises
    ------
    ValueError
        Bad points; k out of range; ``distances`` not 2-D or non-finite.
    TypeError
        k not an integer.

    Examples
    --------
    >>> mean_spacing([[0, 0, 0], [1, 0, 0], [3, 0, 0]], k=1)
    1.3333333333333333
    """
    if distances is None:
        pts = as_points(points)
        k = as_int(k, "k", lo=1, hi=pts.shape[0] - 1, note="the number of other points")
        _, distances = query_knn(pts, k + 1)
    else:
        distances = np.asarray(distances, dtype=np.float64)
        if distances.ndim != 2 or distances.shape[0] < 1:
            raise ValueError(f"distances must have shape (N, m) with N >= 1; got {distances.shape}")
        k = as_int(k, "k", lo=1, hi=distances.shape[1] - 1, note="columns of distances minus 1")
        if not np.isfinite(distances[:, 1 : k + 1]).all():
            raise ValueError("distances must be finite")
    return float(np.mean(distances[:, 1 : k + 1]))
