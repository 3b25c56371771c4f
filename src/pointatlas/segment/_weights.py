"""Point weights of VSA: the area proxy of Eq. 4.6 (`area_weights`)."""

from __future__ import annotations

import numpy as np

from .._core import as_points, check_neighbors
from ._graph import _check_k, neighbor_graph

__all__ = ["area_weights"]


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
        Precomputed neighbour table (e.g. `pointatlas.neighbors.query_knn` indices;
        entries < 0 mean "no neighbour").

    Returns
    -------
    weights : ndarray of shape (N,), float64
        Non-negative weights in squared input units.

    Raises
    ------
    ValueError
        Bad points, k outside [1, N], a neighbour table of the wrong shape or
        with indices >= N.
    TypeError
        k not an integer, a non-integer neighbour table.

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
        table = check_neighbors(neighbors, pts.shape[0], allow_negative=True)
    valid = table >= 0
    diff = pts[np.where(valid, table, 0)] - pts[:, None, :]
    sq = np.einsum("ijk,ijk->ij", diff, diff)
    return np.where(valid, sq, 0.0).sum(axis=1)


def resolve_weights(weights, n, pts=None, table=None, indptr=None, indices=None):
    """The (N,) weights of `VSAOptions.weights` (validated): ones, a copy of the
    given array (its length checked against ``n``), or the area weights of
    ``pts`` over the rows of ``table`` (or, without a table, of the sparse
    adjacency ``indptr, indices``)."""
    if isinstance(weights, str):
        if weights == "uniform":
            return np.ones(n)
        if table is None:  # sparse adjacency given: use its rows
            rows = np.repeat(np.arange(n), np.diff(indptr))
            diff = pts[indices] - pts[rows]
            return np.bincount(rows, weights=np.einsum("ij,ij->i", diff, diff), minlength=n)
        return area_weights(pts, neighbors=table)
    if weights.shape != (n,):
        raise ValueError(f"weights must have shape ({n},); got {weights.shape}")
    return weights.copy()
